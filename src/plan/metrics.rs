//! Plan quality metrics, computed the same way for the input and the plan.
//!
//! Per segment (consecutive waypoints of one continuous section) with part-
//! frame length `L` and machine deltas `ΔX, ΔY, ΔZ, Δtilt, ΔC` (C unwound):
//! the move takes `t = max(L / feed, |ΔX|/vX, |ΔY|/vY, |ΔZ|/vZ,
//! |Δtilt|/ω_tilt, |ΔC|/ω_C)` — the slowest axis sets the pace — and the tip
//! moves over the part at `v = L / t`. The segment violates the extruder's
//! range when `v < v_min` or `v > v_max` (paper 000, Eq. 2 and Fig. 10).
//! `J` is Eq. 7 summed over all segments (degrees); the largest single-step
//! `|Δtilt| + |ΔC|` is reported too.

use crate::kinematics::{Axes, Machine};
use serde::Serialize;

/// One side of the report (`input` or `plan`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    /// Waypoints.
    pub waypoints: usize,
    /// Waypoints whose pose collides.
    pub residual_collisions: usize,
    /// Segments whose motion collides between the waypoints.
    pub colliding_edges: usize,
    /// Share of segments whose tip speed leaves [v_min, v_max] (percent).
    pub speed_violation_pct: f64,
    /// Eq. 7: total |Δtilt| + |ΔC| (degrees).
    pub j_deg: f64,
    /// Largest single-step |Δtilt| + |ΔC| (degrees).
    pub max_step_deg: f64,
    /// Waypoints in the singular region.
    pub singular_waypoints: usize,
    /// Breaks in the toolpath (lift and travel inside a section).
    pub breaks: usize,
    /// Waypoints whose axes leave the machine's ranges (X, Y, Z, tilt, and C
    /// where the machine limits it).
    pub axis_limit_violations: usize,
    /// Largest angle between a waypoint's orientation and its input one (degrees).
    pub max_deviation_deg: f64,
    /// Mean of that angle (degrees).
    pub mean_deviation_deg: f64,
}

/// Tip speed over the part for a move of part-frame length `len` between
/// two configurations.
pub fn tip_speed(m: &Machine, len: f64, a: &Axes, b: &Axes) -> f64 {
    let t = [
        len / m.feed,
        (b.xyz[0] - a.xyz[0]).abs() / m.x.speed,
        (b.xyz[1] - a.xyz[1]).abs() / m.y.speed,
        (b.xyz[2] - a.xyz[2]).abs() / m.z.speed,
        (b.tilt - a.tilt).abs().to_degrees() / m.tilt.speed,
        (b.c - a.c).abs().to_degrees() / m.c.speed,
    ]
    .into_iter()
    .fold(0.0, f64::max);
    if t > 0.0 {
        len / t
    } else {
        0.0
    }
}

/// Accumulates segment statistics.
#[derive(Default)]
pub struct SegmentStats {
    segments: usize,
    violations: usize,
    j: f64,
    max_step: f64,
}

impl SegmentStats {
    /// Add the segment `a → b` of part-frame length `len`.
    pub fn add(&mut self, m: &Machine, len: f64, a: &Axes, b: &Axes) {
        let step = ((b.tilt - a.tilt).abs() + (b.c - a.c).abs()).to_degrees();
        self.j += step;
        self.max_step = self.max_step.max(step);
        if len <= 0.0 {
            return; // Repeated waypoint: no speed to speak of.
        }
        self.segments += 1;
        let v = tip_speed(m, len, a, b);
        let [lo, hi] = m.tip_speed;
        if v < lo * (1.0 - 1e-9) || v > hi * (1.0 + 1e-9) {
            self.violations += 1;
        }
    }

    /// Fill the segment fields of `out`.
    pub fn finish(&self, out: &mut Metrics) {
        out.j_deg = self.j;
        out.max_step_deg = self.max_step;
        out.speed_violation_pct = 100.0 * self.violations as f64 / self.segments.max(1) as f64;
    }
}

/// Is `a` outside the machine's axis ranges?
pub fn outside_limits(m: &Machine, a: &Axes) -> bool {
    let out = |v: f64, l: &crate::kinematics::AxisLimits| v < l.min || v > l.max;
    out(a.xyz[0], &m.x)
        || out(a.xyz[1], &m.y)
        || out(a.xyz[2], &m.z)
        || out(a.tilt.to_degrees(), &m.tilt)
        || m.c
            .range
            .is_some_and(|[lo, hi]| a.c.to_degrees() < lo || a.c.to_degrees() > hi)
}
