//! What a move between two waypoints costs the graph search, in degrees of
//! rotary motion (paper 000's J, Eq. 7), with time and defects converted
//! at the slower rotary axis' speed `ω` (1 s of machine time = `ω`
//! degrees):
//!
//! - **printing** from configuration `a` to `b` over a bead of length `L`:
//!   `|Δtilt| + |ΔC|`, plus, when the tip speed leaves the extruder's range
//!   (the rotary axes cannot keep up, so the extruder dwells and leaves a
//!   blob), `ω · K · dwell` with `dwell = t − L / v_min` seconds (`t` the
//!   move's duration by the slowest axis) and `K` = [`CostModel::dwell_weight`];
//! - **a break** (retract, lift, travel, approach, prime, then go on):
//!   `|Δtilt| + |ΔC|` (the rotation still happens, off the part), plus `ω`
//!   times the break's own duration from the machine file's travel
//!   settings, plus the bead it leaves unprinted, priced like a blob: a
//!   gap of `L` mm misplaces as much bead as `L / v_min` seconds of dwell.
//!
//! So a rotation the extruder can follow costs what the paper's J says; one
//! it cannot costs its blob, and the search weighs that against going round
//! (a break) or spreading the rotation over neighbouring waypoints.

use crate::kinematics::{wrap, Axes, Machine};

/// How the C axis is counted between two configurations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Winding {
    /// C turns without limit: configurations carry C wrapped to (−π, π] and
    /// every move takes the shorter way round.
    Free,
    /// C has a range: configurations carry their absolute C and moves turn
    /// by exactly the difference.
    Absolute,
}

impl Winding {
    /// The C motion from `a` to `b` (radians, signed).
    pub fn dc(self, a: f64, b: f64) -> f64 {
        match self {
            Winding::Free => wrap(b - a),
            Winding::Absolute => b - a,
        }
    }
}

/// A section's printing parameters and the machine's speeds, as the graph
/// needs them.
#[derive(Clone, Copy, Debug)]
pub struct CostModel {
    /// Commanded print feed (mm/s).
    pub feed: f64,
    /// Tip-speed range the extruder can feed (mm/s).
    pub tip_speed: [f64; 2],
    /// Linear axis speeds (mm/s).
    pub linear: [f64; 3],
    /// Tilt and C speeds (degrees/s).
    pub rotary: [f64; 2],
    /// Degrees per second of machine time (the slower rotary axis).
    pub omega: f64,
    /// Weight of a second of dwell (over-extrusion in place) relative to a
    /// second of machine time.
    pub dwell_weight: f64,
    /// A break's own duration (s), rotation excluded.
    pub break_seconds: f64,
    /// How C is counted.
    pub winding: Winding,
}

impl CostModel {
    /// The model for printing with `feed` and `tip_speed` on `m`.
    pub fn new(m: &Machine, feed: f64, tip_speed: [f64; 2], dwell_weight: f64) -> CostModel {
        CostModel {
            feed,
            tip_speed,
            linear: [m.x.speed, m.y.speed, m.z.speed],
            rotary: [m.tilt.speed, m.c.speed],
            omega: m.tilt.speed.min(m.c.speed),
            dwell_weight,
            break_seconds: m.travel.break_seconds(),
            winding: if m.c.range.is_some() {
                Winding::Absolute
            } else {
                Winding::Free
            },
        }
    }

    /// Seconds the move `a → b` takes over a bead of length `len`: the
    /// slowest of the feed and every axis.
    pub fn duration(&self, len: f64, a: &Axes, b: &Axes) -> f64 {
        let dc = self.winding.dc(a.c, b.c).abs().to_degrees();
        let dt = (b.tilt - a.tilt).abs().to_degrees();
        [
            len / self.feed,
            (b.xyz[0] - a.xyz[0]).abs() / self.linear[0],
            (b.xyz[1] - a.xyz[1]).abs() / self.linear[1],
            (b.xyz[2] - a.xyz[2]).abs() / self.linear[2],
            dt / self.rotary[0],
            dc / self.rotary[1],
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }

    /// Seconds the extruder dwells beyond its range on this move (0 when
    /// the tip speed is inside it).
    pub fn dwell(&self, len: f64, a: &Axes, b: &Axes) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let t = self.duration(len, a, b);
        let [lo, hi] = self.tip_speed;
        (t - len / lo).max(len / hi - t).max(0.0)
    }

    /// `|Δtilt| + |ΔC|` in degrees.
    pub fn rotation_deg(&self, a: &Axes, b: &Axes) -> f64 {
        ((b.tilt - a.tilt).abs() + self.winding.dc(a.c, b.c).abs()).to_degrees()
    }

    /// Cost of printing `a → b` over a bead of length `len` (degrees).
    pub fn print_cost(&self, len: f64, a: &Axes, b: &Axes) -> f64 {
        self.print_cost_turning(self.rotation_deg(a, b), len, a, b)
    }

    /// [`CostModel::print_cost`] given its rotation `r`
    /// ([`CostModel::rotation_deg`] of `a`, `b`): never less than `r`.
    pub fn print_cost_turning(&self, r: f64, len: f64, a: &Axes, b: &Axes) -> f64 {
        let d = self.dwell(len, a, b);
        if d > 0.0 {
            r + self.omega * self.dwell_weight * d
        } else {
            r
        }
    }

    /// Cost of a break from `a` to `b` across a bead of length `len`
    /// (degrees).
    pub fn break_cost(&self, len: f64, a: &Axes, b: &Axes) -> f64 {
        self.rotation_deg(a, b) + self.break_beyond_rotation(len)
    }

    /// What a break across a bead of length `len` costs beyond its
    /// rotation (degrees, not negative): its own time and the bead it
    /// leaves out.
    pub fn break_beyond_rotation(&self, len: f64) -> f64 {
        let gap = len / self.tip_speed[0];
        self.omega * (self.break_seconds + self.dwell_weight * gap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_swing_on_a_short_bead_costs_more_than_a_break() {
        let m = Machine::default();
        let cm = CostModel::new(&m, m.feed, m.tip_speed, 10.0);
        let a = m.axes_at([10.0, 0.0, 45.0], (0.3, 0.0));
        let small = m.axes_at([10.5, 0.0, 45.0], (0.3, 0.01));
        let swing = m.axes_at([10.5, 0.0, 45.0], (0.3, 2.0));
        // A small rotation is its J.
        assert!((cm.print_cost(0.5, &a, &small) - cm.rotation_deg(&a, &small)).abs() < 1e-9);
        // 115° of C over half a millimetre: the extruder dwells ~8 s.
        assert!(cm.dwell(0.5, &a, &swing) > 7.0);
        assert!(cm.print_cost(0.5, &a, &swing) > cm.break_cost(0.5, &a, &swing));
    }
}
