//! Numbers with a fixed number of decimals, as `format!("{x:.d$}")` writes
//! them, without its slow path.
//!
//! The standard formatter rounds the exact decimal value of `x`; when its
//! fast algorithm (Grisu) cannot decide, it falls back to big-number
//! arithmetic (Dragon), which is slow for the many millions of numbers
//! the outputs hold. Here `|x| · 10^d` is rounded in `f64` instead. That
//! product is within a few units in the last place of the exact one, so
//! both round to the same integer unless the product lies that close to
//! a half: then (and for huge or non-finite values) the standard
//! formatter is asked. The text is
//! byte-for-byte the standard formatter's (`fixed_matches_the_standard_formatter`).

use std::fmt::Write;

/// Powers of ten that `f64` holds exactly, for up to 9 decimals.
const POW10: [f64; 10] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// Append `x` with `decimals` (≤ 9) decimals to `out`: the same text as
/// `write!(out, "{x:.decimals$}")`. The digits are written right to left
/// into a buffer on the stack and appended at once (plan.csv and the
/// program of a 700 k-waypoint part are 15 M numbers).
pub fn push_fixed(out: &mut String, x: f64, decimals: usize) {
    let Some(mut k) = rounded(x, decimals) else {
        let _ = write!(out, "{x:.decimals$}");
        return;
    };
    // Sign, up to 15 integer digits (`rounded` keeps `k` below 10¹⁵), a
    // point and the decimals.
    let mut buf = [b'0'; 32];
    let mut i = buf.len();
    for _ in 0..decimals {
        i -= 1;
        buf[i] = b'0' + (k % 10) as u8;
        k /= 10;
    }
    if decimals > 0 {
        i -= 1;
        buf[i] = b'.';
    }
    loop {
        i -= 1;
        buf[i] = b'0' + (k % 10) as u8;
        k /= 10;
        if k == 0 {
            break;
        }
    }
    if x.is_sign_negative() {
        i -= 1;
        buf[i] = b'-';
    }
    out.push_str(std::str::from_utf8(&buf[i..]).expect("ascii digits"));
}

/// `|x| · 10^decimals` rounded to the nearest integer, when rounding the
/// `f64` product certainly gives the exact value's rounding; `None` near a
/// half, for huge values and for non-finite ones.
fn rounded(x: f64, decimals: usize) -> Option<u64> {
    let y = x.abs() * POW10[decimals];
    // Within 2⁻⁵² · y of the exact product; a margin of ten times that
    // (plus a little for tiny values) keeps clear of every half.
    let near_half = ((y - y.floor()) - 0.5).abs() <= y * 2e-15 + 1e-12;
    (y < 1e15 && !near_half).then(|| y.round() as u64)
}

/// `x` with `decimals` decimals ([`push_fixed`]).
pub fn fixed(x: f64, decimals: usize) -> String {
    let mut s = String::with_capacity(16);
    push_fixed(&mut s, x, decimals);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Every text is the standard formatter's, for every number of
    /// decimals the outputs use and more: values on the written grid (the
    /// G-code's), halves and near-halves of the last decimal, signed zeros,
    /// tiny, huge and non-finite values, and random values at many scales.
    #[test]
    fn fixed_matches_the_standard_formatter() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            0.0625,
            -0.0625,
            0.0005,
            1.0005,
            -0.0004,
            123.4565,
            1e-12,
            -1e-12,
            1e14,
            1e16,
            -3e20,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for _ in 0..60_000 {
            let scale = 10f64.powi(rng.random_range(-6..=7));
            let v: f64 = rng.random_range(-1.0..1.0) * scale;
            values.push(v);
            // On the grid of three decimals, as the program writes.
            values.push((v * 1000.0).round() / 1000.0);
            // Halves of the last decimal, and their neighbours.
            let d = rng.random_range(0..=6);
            let half = ((v * POW10[d]).floor() + 0.5) / POW10[d];
            values.extend([half, half.next_up(), half.next_down()]);
        }
        for &v in &values {
            for d in 0..=9 {
                assert_eq!(fixed(v, d), format!("{v:.d$}"), "{v:e} with {d} decimals");
            }
        }
    }

    /// The fast path is the one taken: ordinary values (a plan's
    /// coordinates and angles) almost never reach the standard formatter.
    #[test]
    fn ordinary_values_take_the_fast_path() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let n = 100_000;
        let fast = (0..n)
            .filter(|_| rounded(rng.random_range(-500.0..500.0), 3).is_some())
            .count();
        assert!(fast > n - 10, "{fast} of {n} on the fast path");
        assert_eq!(fixed(-123.456_789, 3), "-123.457");
        assert_eq!(fixed(-0.000_4, 3), "-0.000");
    }
}
