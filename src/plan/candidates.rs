//! Collision-free variants for colliding waypoints (paper 000, Sec. III-A;
//! paper 002, heuristic 1): orientations sampled on the sphere within `β`
//! of the waypoint's orientation, outside the singular region, widened by
//! 10 % until one is free — or grown ring by ring (10° apart) instead.

use super::singular::is_singular;

type N = [f64; 3];

/// How variants are generated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// `k` uniform samples on the cap of half-angle β (fixed seed).
    Random {
        /// Samples per round.
        k: usize,
    },
    /// Rings every 10° of tilt, 12 azimuths each, nearest ring first.
    Rings,
}

fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The direction at polar angle `theta` and azimuth `phi` around `n`.
pub fn around(n: N, theta: f64, phi: f64) -> N {
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = {
        let c = [
            n[1] * helper[2] - n[2] * helper[1],
            n[2] * helper[0] - n[0] * helper[2],
            n[0] * helper[1] - n[1] * helper[0],
        ];
        let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        [c[0] / l, c[1] / l, c[2] / l]
    };
    let v = [
        n[1] * u[2] - n[2] * u[1],
        n[2] * u[0] - n[0] * u[2],
        n[0] * u[1] - n[1] * u[0],
    ];
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    std::array::from_fn(|k| ct * n[k] + st * (cp * u[k] + sp * v[k]))
}

/// Round `round` of candidate orientations for waypoint `seed` around `n`:
/// random samples within `beta · 1.1^round`, or ring `round + 1`.
/// Singular directions (within `alpha` of +z) are left out. Empty when the
/// sampling is exhausted (cap beyond 90°, or no rings left).
pub fn round(n: N, seed: u64, round: u32, how: Sampling, beta: f64, alpha: f64) -> Vec<N> {
    let out: Vec<N> = match how {
        Sampling::Random { k } => {
            let cap = beta * 1.1f64.powi(round as i32);
            if cap > std::f64::consts::FRAC_PI_2 * 1.1 {
                return Vec::new();
            }
            let cap = cap.min(std::f64::consts::FRAC_PI_2);
            (0..k as u64)
                .map(|j| {
                    let h = splitmix(
                        seed.wrapping_mul(0x1000_0001)
                            .wrapping_add(j + 1000 * round as u64),
                    );
                    let cos_t = 1.0 - unit(h) * (1.0 - cap.cos());
                    let phi = unit(splitmix(h)) * std::f64::consts::TAU;
                    around(n, cos_t.clamp(-1.0, 1.0).acos(), phi)
                })
                .collect()
        }
        Sampling::Rings => {
            let tilt = 10f64.to_radians() * (round + 1) as f64;
            if tilt > std::f64::consts::FRAC_PI_2 + 1e-9 {
                return Vec::new();
            }
            (0..12)
                .map(|j| around(n, tilt, j as f64 * 30f64.to_radians()))
                .collect()
        }
    };
    out.into_iter()
        .filter(|d| !is_singular(*d, alpha))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_stay_in_the_cap_and_out_of_the_singular_region() {
        let n = [0.0, 0.0, 1.0];
        let s = round(
            n,
            7,
            0,
            Sampling::Random { k: 64 },
            45f64.to_radians(),
            4.5f64.to_radians(),
        );
        assert!(s.len() > 50);
        for d in &s {
            let a = d[2].acos();
            assert!(a <= 45f64.to_radians() + 1e-9 && a > 4.5f64.to_radians());
        }
        let r = round([1.0, 0.0, 0.0], 1, 2, Sampling::Rings, 0.0, 0.0);
        assert_eq!(r.len(), 12);
        for d in &r {
            assert!((d[0].acos() - 30f64.to_radians()).abs() < 1e-9);
        }
    }
}
