//! The singular region and its processing (paper 000, Eq. 6 and Sec. III-B).
//!
//! A waypoint is singular when its nozzle direction lies within `α` of +z
//! (`√((nx/nz)² + (ny/nz)²) ≤ tan α`, nz > 0): there C is ill-conditioned
//! and small orientation changes demand large C moves. Each maximal run of
//! singular waypoints gets rotary angles of its own:
//! - a run at the start (end) of a section takes its far (near) anchor's
//!   angles — the anchor is the first non-singular waypoint after (before);
//! - between two anchors whose C differ by at most π/2, the run follows the
//!   minor arc of the cone boundary (tilt α) from one anchor's C to the
//!   other's;
//! - otherwise it crosses the pole towards the far anchor's flipped solution
//!   `(−tilt, C + π)`, whose C is closer.
//!
//! A section entirely singular holds tilt 0 and C 0.
//! The angles are the `tilt ≤ 0` member of the IK pair; the graph adds the
//! mirrored member `(−tilt, C + π)` of the same orientation.

use crate::kinematics::{ik_angles, wrap, Rotary};
use glam::DVec2;
use std::f64::consts::FRAC_PI_2;

/// Is unit direction `n` in the singular region of half-angle `alpha`?
pub fn is_singular(n: [f64; 3], alpha: f64) -> bool {
    n[2] > 0.0 && DVec2::new(n[0], n[1]).length() <= alpha.tan() * n[2]
}

/// Rotary angles for the singular waypoints of one section (`None` for the
/// others), and the singular flags.
pub fn process(rot: Rotary, n: &[[f64; 3]], alpha: f64) -> (Vec<Option<(f64, f64)>>, Vec<bool>) {
    let flags: Vec<bool> = n.iter().map(|v| is_singular(*v, alpha)).collect();
    let mut fixed = vec![None; n.len()];
    let last = n.len().saturating_sub(1);
    let mut i = 0;
    while i < n.len() {
        if !flags[i] {
            i += 1;
            continue;
        }
        let s = i;
        while i + 1 < n.len() && flags[i + 1] {
            i += 1;
        }
        let e = i;
        i += 1;
        let sol = |k: usize| ik_angles(rot, n[k])[0];
        match (s > 0, e < last) {
            (false, false) => fixed[s..=e].fill(Some((0.0, 0.0))),
            (false, true) => fixed[s..=e].fill(Some(sol(e + 1))),
            (true, false) => fixed[s..=e].fill(Some(sol(s - 1))),
            (true, true) => {
                let (a, b) = (s - 1, e + 1);
                let (ta, ca) = sol(a);
                let (tb, cb) = sol(b);
                let span = (b - a) as f64;
                let dc = wrap(cb - ca);
                for (k, f) in fixed.iter_mut().enumerate().take(e + 1).skip(s) {
                    let t = (k - a) as f64 / span;
                    *f = Some(if dc.abs() <= FRAC_PI_2 {
                        // Minor arc on the cone boundary.
                        (-alpha, wrap(ca + t * dc))
                    } else {
                        // Through the pole to the far anchor's flipped solution.
                        let dc2 = wrap(cb + std::f64::consts::PI - ca);
                        (ta + t * (-tb - ta), wrap(ca + t * dc2))
                    });
                }
            }
        }
    }
    (fixed, flags)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::orientation;

    const A: f64 = 0.0785398; // 4.5°

    fn dir(tilt_deg: f64, az_deg: f64) -> [f64; 3] {
        let (t, a) = (tilt_deg.to_radians(), az_deg.to_radians());
        [t.sin() * a.cos(), t.sin() * a.sin(), t.cos()]
    }

    #[test]
    fn eq6_region() {
        assert!(is_singular(dir(4.0, 33.0), A));
        assert!(!is_singular(dir(5.0, 33.0), A));
        assert!(!is_singular([0.0, 0.0, -1.0], A));
    }

    #[test]
    fn runs_at_start_and_end_take_their_anchor() {
        let n = vec![
            dir(1.0, 0.0),
            dir(2.0, 90.0),
            dir(10.0, 40.0),
            dir(12.0, 50.0),
            dir(3.0, 10.0),
        ];
        let (f, flags) = process(Rotary::BC, &n, A);
        assert_eq!(flags, vec![true, true, false, false, true]);
        assert_eq!(f[0], Some(ik_angles(Rotary::BC, n[2])[0]));
        assert_eq!(f[1], f[0]);
        assert_eq!(f[2], None);
        assert_eq!(f[4], Some(ik_angles(Rotary::BC, n[3])[0]));
    }

    #[test]
    fn a_wholly_singular_section_holds_still() {
        let n = vec![dir(1.0, 0.0), dir(2.0, 120.0), dir(0.5, 240.0)];
        let (f, flags) = process(Rotary::BC, &n, A);
        assert!(flags.iter().all(|&s| s));
        assert!(f.iter().all(|x| *x == Some((0.0, 0.0))));
    }

    #[test]
    fn minor_arc_stays_on_the_cone_boundary() {
        // Anchors at azimuths 0° and 60°: the run sweeps C by 60° at tilt α.
        let n = vec![
            dir(8.0, 0.0),
            dir(2.0, 200.0),
            dir(1.0, 10.0),
            dir(3.0, 300.0),
            dir(8.0, 60.0),
        ];
        let (f, _) = process(Rotary::BC, &n, A);
        let c0 = ik_angles(Rotary::BC, n[0])[0].1;
        for (k, fk) in f.iter().enumerate().take(4).skip(1) {
            let (t, c) = fk.unwrap();
            assert!((t + A).abs() < 1e-12);
            let want = wrap(c0 - (k as f64 * 15.0).to_radians());
            assert!((wrap(c - want)).abs() < 1e-9, "k {k}: {c} vs {want}");
            // On the boundary: exactly α from +z.
            let v = orientation(Rotary::BC, t, c);
            assert!((v[2].acos() - A).abs() < 1e-9);
        }
    }

    #[test]
    fn opposite_anchors_flip_through_the_pole() {
        // Azimuths 0° and 170°: C would swing 170°; the flip crosses the pole
        // with a 10° C change and the tilt changing sign.
        let n = vec![
            dir(6.0, 0.0),
            dir(1.0, 90.0),
            dir(1.0, 100.0),
            dir(6.0, 170.0),
        ];
        let (f, _) = process(Rotary::BC, &n, A);
        let (t1, c1) = f[1].unwrap();
        let (t2, c2) = f[2].unwrap();
        assert!(t1 < 0.0 && t2 > 0.0, "tilt changes sign: {t1} {t2}");
        let c0 = ik_angles(Rotary::BC, n[0])[0].1;
        assert!(
            wrap(c1 - c0).abs() < 10f64.to_radians() && wrap(c2 - c1).abs() < 10f64.to_radians()
        );
    }
}
