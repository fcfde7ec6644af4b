//! Orientation smoothing before planning: the Laplacian pass of paper 000
//! and the zero-phase moving-average / median filters with correction into
//! a tolerance cone of paper 004 (Eqs. 3–7).

use glam::DVec3;

type N = [f64; 3];

/// `v` scaled to unit length, the zero vector left as it is. It divides
/// by the length rather than multiplying by its reciprocal as
/// `normalize()` does: the planned orientations take its last bits.
fn unit(v: DVec3) -> DVec3 {
    let l = v.length();
    if l > 0.0 {
        v / l
    } else {
        v
    }
}

/// Which smoothing to apply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Smoothing {
    /// Leave orientations as they are.
    None,
    /// Gauss–Seidel Laplacian passes, `n_i ← normalise(n_{i−1} + ½ n_i + n_{i+1})`,
    /// ends fixed (paper 000's preprocessing; its authors' code runs one pass).
    Laplacian {
        /// Number of passes.
        passes: usize,
    },
    /// Zero-phase moving average over `window` waypoints, corrected into a
    /// cone of half-angle `cone_deg` around the input (paper 004).
    MovingAverage {
        /// Window length (waypoints).
        window: usize,
        /// Tolerance cone half-angle (degrees).
        cone_deg: f64,
    },
    /// Zero-phase component-wise median, corrected likewise.
    Median {
        /// Window length (waypoints).
        window: usize,
        /// Tolerance cone half-angle (degrees).
        cone_deg: f64,
    },
}

/// Smooth one continuous section of unit orientations.
pub fn smooth(n: &[N], how: Smoothing) -> Vec<N> {
    let n: Vec<DVec3> = n.iter().map(|&v| DVec3::from(v)).collect();
    let smoothed = match how {
        Smoothing::None => n,
        Smoothing::Laplacian { passes } => (0..passes).fold(n, |acc, _| laplacian(&acc)),
        Smoothing::MovingAverage { window, cone_deg } => {
            let f = zero_phase(&n, window, average);
            correct_into_cone(&n, &f, cone_deg.to_radians())
        }
        Smoothing::Median { window, cone_deg } => {
            let f = zero_phase(&n, window, median);
            correct_into_cone(&n, &f, cone_deg.to_radians())
        }
    };
    smoothed.iter().map(DVec3::to_array).collect()
}

fn laplacian(n: &[DVec3]) -> Vec<DVec3> {
    let mut out = n.to_vec();
    for i in 1..n.len().saturating_sub(1) {
        out[i] = unit(out[i - 1] + 0.5 * n[i] + n[i + 1]);
    }
    out
}

fn average(w: &[DVec3]) -> DVec3 {
    unit(w.iter().fold(DVec3::ZERO, |s, &v| s + v))
}

fn median(w: &[DVec3]) -> DVec3 {
    let mut out = DVec3::ZERO;
    for k in 0..3 {
        let mut c: Vec<f64> = w.iter().map(|v| v[k]).collect();
        c.sort_by(f64::total_cmp);
        out[k] = c[c.len() / 2];
    }
    unit(out)
}

/// Causal filter of `window` samples run forward, then backward on its
/// output (as MATLAB's `filtfilt`): no lag. Edges use the shorter windows.
fn zero_phase(n: &[DVec3], window: usize, f: fn(&[DVec3]) -> DVec3) -> Vec<DVec3> {
    let w = window.max(1);
    let causal = |x: &[DVec3]| -> Vec<DVec3> {
        (0..x.len())
            .map(|i| f(&x[i.saturating_sub(w - 1)..=i]))
            .collect()
    };
    let fwd = causal(n);
    let mut rev: Vec<DVec3> = fwd.into_iter().rev().collect();
    rev = causal(&rev);
    rev.into_iter().rev().collect()
}

/// Eq. 7: keep a smoothed vector within `half` radians of its input `b`;
/// outside, rotate `b` towards it by exactly `half` (Eqs. 4–6, with the
/// rotation axis `b × T_S` normalised so that the result lands on the
/// smoothed side of the cone).
fn correct_into_cone(b: &[DVec3], t: &[DVec3], half: f64) -> Vec<DVec3> {
    b.iter()
        .zip(t)
        .map(|(&b, &ts)| {
            let a = b.dot(ts).clamp(-1.0, 1.0).acos();
            if a <= half {
                return ts;
            }
            let d = ts.dot(b);
            let u = unit(ts - d * b);
            let (s, c) = half.sin_cos();
            unit(c * b + s * u)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(k: usize) -> Vec<N> {
        (0..k)
            .map(|i| {
                let wobble = if i % 2 == 0 { 0.05 } else { -0.05 };
                unit(DVec3::new(0.3 * (i as f64 * 0.05).sin() + wobble, 0.0, 1.0)).to_array()
            })
            .collect()
    }

    fn dot(a: N, b: N) -> f64 {
        DVec3::from(a).dot(DVec3::from(b))
    }

    fn roughness(n: &[N]) -> f64 {
        n.windows(2)
            .map(|w| dot(w[0], w[1]).clamp(-1.0, 1.0).acos())
            .sum()
    }

    #[test]
    fn every_filter_reduces_roughness_and_keeps_ends_sane() {
        let n = noisy(200);
        for how in [
            Smoothing::Laplacian { passes: 1 },
            Smoothing::MovingAverage {
                window: 9,
                cone_deg: 30.0,
            },
            Smoothing::Median {
                window: 9,
                cone_deg: 30.0,
            },
        ] {
            let s = smooth(&n, how);
            assert_eq!(s.len(), n.len());
            assert!(roughness(&s) < 0.7 * roughness(&n), "{how:?}");
            for v in &s {
                assert!((dot(*v, *v) - 1.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn cone_correction_bounds_the_deviation() {
        let n = noisy(100);
        let s = smooth(
            &n,
            Smoothing::MovingAverage {
                window: 40,
                cone_deg: 1.0,
            },
        );
        for (a, b) in n.iter().zip(&s) {
            assert!(dot(*a, *b).acos() <= 1.0f64.to_radians() + 1e-9);
        }
        // Paper 004's worked case: b = z, T_S at 60°, cone 30° → (0.5, 0, 0.866).
        let c = correct_into_cone(
            &[DVec3::Z],
            &[DVec3::new(60f64.to_radians().sin(), 0.0, 0.5)],
            30f64.to_radians(),
        );
        assert!((c[0].x - 0.5).abs() < 1e-9 && (c[0].z - 0.75f64.sqrt()).abs() < 1e-9);
    }
}
