//! Collision-free variants for colliding waypoints (paper 000, Sec. III-A;
//! paper 002, heuristic 1): orientations sampled on the sphere within `β`
//! of the waypoint's orientation, outside the singular region, widened by
//! 10 % until one is free — or grown ring by ring (10° apart) instead.
//! Before a waypoint is given up, [`reachable_directions`] lists every
//! orientation the machine can reach, at most 5° apart.

use super::singular::is_singular;
use glam::DVec3;

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
    let n = DVec3::from(n);
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    // Divided by the length, not normalize()'s multiplication by its
    // reciprocal: the variants' last bits are the plans'.
    let c = n.cross(helper);
    let u = c / c.length();
    let v = n.cross(u);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    (ct * n + st * (cp * u + sp * v)).to_array()
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

/// Every nozzle direction the machine can reach with |tilt| up to `top`
/// (radians), as IK pairs `[(−τ, c), (τ, c + π)]` (callers drop members
/// outside the tilt range): rings of constant |tilt| `step` apart, azimuths
/// at most `step` apart along each ring, so every direction lies within
/// `step` of one of them and no free cone wider than that is missed.
pub fn reachable_directions(top: f64, step: f64) -> Vec<[(f64, f64); 2]> {
    let top = top.min(std::f64::consts::PI);
    let rings = (top / step).ceil() as usize;
    let mut out = vec![[(0.0, 0.0), (0.0, std::f64::consts::PI)]];
    for j in 1..=rings {
        let tau = (j as f64 * step).min(top);
        let n = ((std::f64::consts::TAU * tau.sin()) / step).ceil().max(1.0) as usize;
        for k in 0..n {
            let c = crate::kinematics::wrap(k as f64 * std::f64::consts::TAU / n as f64);
            out.push([
                (-tau, c),
                (tau, crate::kinematics::wrap(c + std::f64::consts::PI)),
            ]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{orientation, Rotary};

    #[test]
    fn reachable_directions_leave_no_gap_wider_than_the_step() {
        let step = 5f64.to_radians();
        let grid = reachable_directions(90f64.to_radians(), step);
        let dirs: Vec<DVec3> = grid
            .iter()
            .map(|&[(t, c), mirror]| {
                // Both members of a pair point the same way.
                let (a, b) = (
                    DVec3::from(orientation(Rotary::BC, t, c)),
                    DVec3::from(orientation(Rotary::BC, mirror.0, mirror.1)),
                );
                assert!((a - b).abs().element_sum() < 1e-9);
                a
            })
            .collect();
        // Random upper-hemisphere directions all have a grid direction
        // within the covering radius of a `step` lattice.
        let mut h = 12345u64;
        for _ in 0..2000 {
            h = splitmix(h);
            let z = unit(h);
            let phi = unit(splitmix(h ^ 7)) * std::f64::consts::TAU;
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            let best = dirs
                .iter()
                .map(|g| g.dot(d).clamp(-1.0, 1.0).acos())
                .fold(f64::INFINITY, f64::min);
            assert!(best <= step, "gap {}°", best.to_degrees());
        }
        assert!(grid.len() < 1000, "{} directions", grid.len());
    }

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
