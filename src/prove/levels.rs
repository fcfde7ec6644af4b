//! Levels: how much of a move one pose's clearance proves.
//!
//! A pose of a move is *free at level `λ`* when no head point `h` comes
//! within `m + λ (tip + turn |h|)` of material (`m` the safety margin,
//! `tip` and `turn` the move's [`Sweep`]): then no head point reaches the
//! margin while the move advances by a fraction `λ` either way. A level is
//! asked as one query whose margin grows with distance from the tip
//! (`level_query`); what a pose is known to keep (`Clearance`) certifies
//! the levels whose queries ask no more (`plain_level`,
//! `sloped_level`).

use super::bounds::Sweep;

/// What a pose is known to keep: every material point `q` (head frame)
/// at least `plain` from the head, and, from a sloped query, at least
/// `margin + slope · |q|` (`slope` 0: none known). Kept as the queries
/// asked them (f32), 12 bytes a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Clearance {
    pub(super) plain: f32,
    pub(super) margin: f32,
    pub(super) slope: f32,
}

impl Clearance {
    /// Known free at `(margin, slope)`.
    pub(super) fn new(margin: f64, slope: f64) -> Self {
        let (margin, slope) = (margin as f32, slope as f32);
        if slope > 0.0 {
            Clearance {
                plain: margin,
                margin,
                slope,
            }
        } else {
            Clearance {
                plain: margin,
                margin: 0.0,
                slope: 0.0,
            }
        }
    }

    /// What is known, with `other` learnt too.
    pub(super) fn merged(self, other: Clearance) -> Self {
        // The steeper slope certifies more of a turning move's levels.
        let steeper =
            other.slope > self.slope || (other.slope == self.slope && other.margin > self.margin);
        let (margin, slope) = if steeper {
            (other.margin, other.slope)
        } else {
            (self.margin, self.slope)
        };
        Clearance {
            plain: self.plain.max(other.plain),
            margin,
            slope,
        }
    }

    /// The largest level (see [`level_query`]) this certifies for a move
    /// with sweep `s` whose farthest head point travels `bound`, safety
    /// margin `m`.
    pub(super) fn level(&self, m: f64, s: &Sweep, bound: f64) -> f64 {
        let plain = plain_level(self.plain as f64, m, bound);
        if self.slope > 0.0 {
            plain.max(sloped_level(self.margin as f64, self.slope as f64, m, s))
        } else {
            plain
        }
    }
}

/// The level (fraction of its move, see [`level_query`]) a pose known free
/// at the plain margin `margin` certifies, for a move whose farthest
/// moving head point travels `bound` (`m` the safety margin).
pub(super) fn plain_level(margin: f64, m: f64, bound: f64) -> f64 {
    if margin < m {
        f64::NEG_INFINITY
    } else if bound > 0.0 {
        (margin - m) / bound
    } else {
        f64::INFINITY
    }
}

/// The level a pose known free at `(margin, slope)` certifies for a move
/// with sweep `s` (safety margin `m`): the largest `λ` whose
/// [`level_query`] asks no more, `margin ≥ (m + λ tip) / (1 − λ turn)`
/// and `slope ≥ λ turn / (1 − λ turn)`.
pub(super) fn sloped_level(margin: f64, slope: f64, m: f64, s: &Sweep) -> f64 {
    if margin < m {
        return f64::NEG_INFINITY;
    }
    let by_margin = if s.tip + margin * s.turn > 0.0 {
        (margin - m) / (s.tip + margin * s.turn)
    } else {
        f64::INFINITY
    };
    let by_slope = if s.turn > 0.0 {
        slope / ((1.0 + slope) * s.turn)
    } else {
        f64::INFINITY
    };
    by_margin.min(by_slope)
}

/// The query `(margin, slope)` that certifies a pose of a move with sweep
/// `s` at level `λ`: no head point `h` comes within
/// `m + λ (s.tip + s.turn |h|)` of material, so none reaches the margin
/// `m` while the move advances by a fraction `λ` either way. Asking each
/// material point `q` (head frame) to keep `M₀ + k |q|` with
/// `M₀ = (m + λ tip) / (1 − λ turn)`, `k = λ turn / (1 − λ turn)` does it:
/// the head point `h` nearest to `q` has `|h| ≤ |q| + |q − h|`. Material
/// near the tip then needs little more than the tip's own travel, however
/// far the rest of the head swings. Large turns (`λ turn ≥ ½`) ask the
/// plain margin `m + λ · s.within(reach)` instead.
pub(super) fn level_query(m: f64, s: &Sweep, reach: f64, level: f64) -> (f64, f64) {
    let k = level * s.turn;
    if k < 0.5 {
        ((m + level * s.tip) / (1.0 - k), k / (1.0 - k))
    } else {
        (m + level * s.within(reach), 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pose asked at level `λ` keeps every head point `h` at least
    /// `m + λ (tip + turn |h|)` from material: with the material point `q`
    /// at exactly the asked `margin + slope |q|` from the head, every head
    /// point as far from the tip as it can be (`|h| ≤ |q| + |q − h|`).
    #[test]
    fn level_queries_keep_each_head_point_its_own_sweep() {
        let m = 0.05;
        let reach = 36.0;
        for (tip, turn) in [(0.9, 0.01), (0.3, 0.2), (2.0, 0.04), (0.0, 1.5), (1.0, 3.0)] {
            let s = Sweep { tip, turn };
            for level in [0.01, 0.1, 0.25, 0.5, 1.0] {
                let (margin, slope) = level_query(m, &s, reach, level);
                for q in [0.0, 0.5, 3.0, 10.0, 30.0, 36.0] {
                    let gap = margin + slope * q;
                    // The farthest head point at that distance from q.
                    let h: f64 = q + gap;
                    let need = m + level * s.within(h.min(reach));
                    assert!(
                        gap >= need * (1.0 - 1e-12),
                        "sweep {s:?}, level {level}, |q| {q}: {gap} < {need}"
                    );
                }
                // Never asks more of the tip's neighbourhood than one margin
                // for the whole head would.
                assert!(margin <= m + level * s.within(reach) + 1e-12 || slope == 0.0);
            }
        }
    }

    /// A pose known free at a sloped clearance certifies, for a move, the
    /// largest level whose query asks no more than that clearance.
    #[test]
    fn sloped_clearances_certify_the_levels_they_cover() {
        let m = 0.05;
        for (tip, turn) in [(0.5, 0.0), (0.3, 0.02), (0.1, 0.3), (2.0, 0.05)] {
            let s = Sweep { tip, turn };
            for level in [0.05, 0.2, 0.5, 0.9] {
                if level * turn >= 0.5 {
                    continue;
                }
                let (margin, slope) = level_query(m, &s, 36.0, level);
                let got = sloped_level(margin, slope, m, &s);
                assert!(
                    (got - level).abs() <= 1e-9 * level.max(1.0) || (turn == 0.0 && got >= level),
                    "sweep {s:?}, level {level}: certified {got}"
                );
                // A little less clearance certifies less.
                assert!(sloped_level(margin * 0.99, slope, m, &s) < level);
            }
        }
        // A plain clearance certifies by the head's whole sweep.
        let c = Clearance::new(0.2, 0.0);
        let s = Sweep {
            tip: 0.3,
            turn: 0.01,
        };
        // (Kept as the query asked it: in f32.)
        let want = (0.2f32 as f64 - m) / s.within(36.0);
        assert!((c.level(m, &s, s.within(36.0)) - want).abs() < 1e-12);
    }
}
