//! Numbers read from text as the standard parser reads them, faster for
//! the short decimals toolpath and mesh files are made of.

/// Powers of ten that `f32` holds exactly.
const POW10_F32: [f32; 11] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// The `f32` that `str::parse` makes of `word`, `None` where it fails.
/// Plain decimals (`-12.3456`: a sign, digits, a point, digits) whose
/// digits make an integer `m ≤ 2²⁴` with at most ten after the point are
/// `m / 10^k` in `f32`: both are exact, and one correctly rounded
/// division is the correctly rounded value (Clinger's fast path, the one
/// the standard parser takes for them too). Anything else — exponents,
/// more digits, words that are not numbers — goes to `str::parse`.
pub fn parse_f32(word: &[u8]) -> Option<f32> {
    let (negative, digits) = match word.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, word),
    };
    let mut m: u32 = 0;
    let mut seen = 0usize;
    let mut after_point: Option<usize> = None;
    let mut fast = !digits.is_empty();
    for &b in digits {
        match b {
            b'0'..=b'9' if m <= (1 << 24) / 10 => {
                m = m * 10 + (b - b'0') as u32;
                seen += 1;
                if let Some(k) = after_point.as_mut() {
                    *k += 1;
                }
            }
            b'.' if after_point.is_none() => after_point = Some(0),
            _ => {
                fast = false;
                break;
            }
        }
    }
    let k = after_point.unwrap_or(0);
    if fast && seen > 0 && m <= 1 << 24 && k < POW10_F32.len() {
        let v = m as f32 / POW10_F32[k];
        return Some(if negative { -v } else { v });
    }
    std::str::from_utf8(word).ok()?.parse().ok()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A number as exporters write them: plain, signed, exponent, many digits.
    pub(crate) fn number(rng: &mut ChaCha8Rng) -> String {
        let x: f64 = rng.random_range(-500.0..500.0);
        match rng.random_range(0..6) {
            0 => format!("{x:.4}"),
            1 => format!("{x}"),
            2 => format!("{x:e}"),
            3 => format!("{}", x.round() as i64),
            4 => format!("{:.9}", x / 1e3),
            _ => format!("+{:.2}", x.abs()),
        }
    }

    #[test]
    fn numbers_convert_as_the_standard_parser_converts_them() {
        let same = |w: &str| {
            let std: Option<f32> = w.parse().ok();
            let fast = parse_f32(w.as_bytes());
            assert_eq!(fast.map(f32::to_bits), std.map(f32::to_bits), "{w:?}");
        };
        for w in [
            ".",
            "+.",
            "-.",
            ".5",
            "+.5",
            "-.5",
            "5.",
            "-0",
            "+0",
            "-0.0",
            "0.0000000001",
            "0.00000000001",
            "16777216",
            "16777217",
            "1677721.6",
            "1.6777217",
            "167772.16",
            "0.1",
            "0.2",
            "0.3",
            "3.4028236",
            "inf",
            "-inf",
            "NaN",
            "1e5",
            "1E-3",
            "--1",
            "1..2",
            "1.2.3",
            "0x10",
            "1,5",
            "12a",
            "007.250",
        ] {
            same(w);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200_000 {
            let digits = rng.random_range(1..10);
            let point = rng.random_range(0..=digits);
            let mut w = String::new();
            match rng.random_range(0..3) {
                0 => w.push('-'),
                1 => w.push('+'),
                _ => {}
            }
            for d in 0..digits {
                if d == point {
                    w.push('.');
                }
                w.push((b'0' + rng.random_range(0..10u8)) as char);
            }
            same(&w);
            same(&number(&mut rng));
        }
    }
}
