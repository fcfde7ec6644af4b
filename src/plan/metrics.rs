//! Plan quality metrics, computed the same way for the input and the plan.
//!
//! Per segment (consecutive waypoints printed one after the other) with
//! part-frame length `L` and machine deltas `ΔX, ΔY, ΔZ, Δtilt, ΔC` (C
//! unwound): the move takes `t = max(L / feed, |ΔX|/vX, |ΔY|/vY, |ΔZ|/vZ,
//! |Δtilt|/ω_tilt, |ΔC|/ω_C)` — the slowest axis sets the pace — and the tip
//! moves over the part at `v = L / t`. The segment violates the extruder's
//! range when `v < v_min` or `v > v_max` (paper 000, Eq. 2 and Fig. 10).
//! `J` is Eq. 7 summed over all segments (degrees); the largest single-step
//! `|Δtilt| + |ΔC|` is reported too. Feed and range are the extruder's that
//! prints the segment (support layers: the support tool's).

use super::cost::CostModel;
use crate::kinematics::{Axes, Machine};
use glam::DVec3;
use serde::Serialize;

/// One side of the report (`input` or `plan`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    /// Waypoints.
    pub waypoints: usize,
    /// Visited waypoints whose pose comes within the margin of material.
    pub residual_collisions: usize,
    /// Moves that come within the margin of material somewhere (plan: every
    /// move of the written program, re-checked; input: segments between
    /// consecutive waypoints — from or to a colliding pose, proven by the
    /// graph where the plan kept both poses, else sampled — a lower bound).
    pub colliding_edges: usize,
    /// Moves of the written program checked (plan only).
    pub program_moves: usize,
    /// Share of segments whose tip speed leaves [v_min, v_max] (percent).
    pub speed_violation_pct: f64,
    /// Eq. 7: total |Δtilt| + |ΔC| over printed segments (degrees).
    pub j_deg: f64,
    /// Largest single-step |Δtilt| + |ΔC| (degrees).
    pub max_step_deg: f64,
    /// Waypoints whose (planned, or input) orientation lies in the singular
    /// region — the `singular` / `was_singular` flags of plan.csv.
    pub singular_waypoints: usize,
    /// Breaks in the toolpath (retract, lift, travel, approach inside a section).
    pub breaks: usize,
    /// Waypoints not visited (no safe orientation, or out of the axis ranges).
    pub skipped_waypoints: usize,
    /// Of those, waypoints outside the machine's axis ranges in every orientation.
    pub unreachable_waypoints: usize,
    /// Of those, waypoints with no printed bead on either side (nothing to
    /// print there).
    pub isolated_waypoints: usize,
    /// Program positions outside the machine's axis ranges (input: waypoints).
    pub axis_limit_violations: usize,
    /// Largest distance of the nozzle tip from its bead while extruding,
    /// under joint-linear interpolation (mm; plan only).
    pub tip_deviation_max_mm: f64,
    /// Largest C rotation between two extruding moves (degrees; plan only).
    pub travel_c_max_deg: f64,
    /// Share of printed segments whose layer height is the clamp's bound,
    /// not a measurement (percent; plan only).
    pub height_clamped_pct: f64,
    /// Largest angle between a waypoint's orientation and its input one (degrees).
    pub max_deviation_deg: f64,
    /// Mean of that angle (degrees).
    pub mean_deviation_deg: f64,
}

/// Tip speed over the part for a move of part-frame length `len` between
/// two configurations, printing with `cm`'s feed.
pub fn tip_speed(cm: &CostModel, len: f64, a: &Axes, b: &Axes) -> f64 {
    let t = cm.duration(len, a, b);
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
    pub fn add(&mut self, cm: &CostModel, len: f64, a: &Axes, b: &Axes) {
        let step = ((b.tilt - a.tilt).abs() + (b.c - a.c).abs()).to_degrees();
        self.j += step;
        self.max_step = self.max_step.max(step);
        if len <= 0.0 {
            return; // Repeated waypoint: no speed to speak of.
        }
        self.segments += 1;
        let v = tip_speed(cm, len, a, b);
        let [lo, hi] = cm.tip_speed;
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
    let out = |v: f64, l: &crate::kinematics::AxisLimits| v < l.min - 1e-9 || v > l.max + 1e-9;
    out(a.xyz[0], &m.x)
        || out(a.xyz[1], &m.y)
        || out(a.xyz[2], &m.z)
        || out(a.tilt.to_degrees(), &m.tilt)
        || m.c
            .range
            .is_some_and(|[lo, hi]| a.c.to_degrees() < lo - 1e-9 || a.c.to_degrees() > hi + 1e-9)
}

/// Largest distance of the tip from the straight segment between its ends
/// over the move `a → b`, sampled as the machine's controller interpolates
/// (64 steps; 0 under tool-centre-point control).
pub fn tip_deviation(m: &Machine, a: &Axes, b: &Axes) -> f64 {
    if m.post.interpolation() == crate::kinematics::Interpolation::TipLinear {
        return 0.0;
    }
    let (pa, pb) = (DVec3::from(m.tip(a)), DVec3::from(m.tip(b)));
    let seg = pb - pa;
    let sl = seg.length_squared().max(1e-18);
    (1..64)
        .map(|k| {
            let d = DVec3::from(m.tip_along(a, b, k as f64 / 64.0)) - pa;
            let u = (d.dot(seg) / sl).clamp(0.0, 1.0);
            (d - u * seg).length()
        })
        .fold(0.0, f64::max)
}
