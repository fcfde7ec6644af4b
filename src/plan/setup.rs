//! What every stage from the columns on reads and none changes — the
//! scene, the machine, the planner's settings and the prepared toolpath —
//! with the rules the stages share: which configurations the machine can
//! take at a waypoint, how C is unwound, which moves print a bead.

use super::cost::{CostModel, Winding};
use super::{half_turn_symmetric, PlanOptions, Prepared};
use crate::kinematics::{ik_angles, round_angle, wrap, Axes, AxisLimits, Machine};
use crate::prove::MoveSpec;
use crate::scene::{cutoff, Scene};

/// The planner's fixed inputs (see the module comment).
pub(super) struct Setup<'a> {
    pub scene: &'a Scene,
    pub machine: &'a Machine,
    pub opts: &'a PlanOptions,
    pub toolpath: &'a Prepared,
    /// A half-turn about the head axis maps the head onto itself
    /// ([`half_turn_symmetric`]): a waypoint's two IK solutions are one
    /// collision query.
    pub symmetric: bool,
}

impl<'a> Setup<'a> {
    /// The inputs of planning `toolpath` (prepared for `machine` and
    /// `opts`) over `scene`.
    pub fn new(
        scene: &'a Scene,
        toolpath: &'a Prepared,
        machine: &'a Machine,
        opts: &'a PlanOptions,
    ) -> Self {
        Setup {
            scene,
            machine,
            opts,
            toolpath,
            symmetric: half_turn_symmetric(scene),
        }
    }

    /// Waypoints of the toolpath.
    pub fn waypoints(&self) -> usize {
        self.toolpath.pos.len()
    }

    /// The axes of `(tilt, c)` at waypoint `g`, when every axis is within
    /// the machine's ranges (C: some whole turn of it).
    pub fn feasible(&self, g: usize, tc: (f64, f64)) -> Option<Axes> {
        let m = self.machine;
        let a = m.axes_at(self.toolpath.pos[g], tc);
        let t = a.tilt.to_degrees();
        let inside = |v: f64, l: &AxisLimits| v >= l.min && v <= l.max;
        let ok = t >= m.tilt.min - 1e-9
            && t <= m.tilt.max + 1e-9
            && inside(a.xyz[0], &m.x)
            && inside(a.xyz[1], &m.y)
            && inside(a.xyz[2], &m.z)
            && m.c.range.is_none_or(|r| !windings(a.c, r).is_empty());
        ok.then_some(a)
    }

    /// Waypoint `g`'s own orientation, as planned around (smoothed, or
    /// given its angles in the singular region), as its IK pair.
    pub fn own_pair(&self, g: usize) -> [(f64, f64); 2] {
        match self.toolpath.singular_angles[g] {
            Some((t, c)) => [(t, c), (-t, wrap(c + std::f64::consts::PI))],
            None => ik_angles(self.machine.rotary, self.toolpath.smoothed_dirs[g]),
        }
    }

    /// The costs of printing `layer`, with its extruder.
    pub fn cost_model(&self, layer: usize) -> CostModel {
        let t = self.machine.tool_for(self.toolpath.layer_is_support[layer]);
        CostModel::new(self.machine, t.feed, t.tip_speed, self.opts.dwell_weight)
    }

    /// The joint-linear moves that print the bead from waypoint `g − 1` at
    /// `a` to `g` at `b`, as the program will write them.
    pub fn print_moves(&self, g: usize, a: &Axes, b: &Axes) -> Vec<MoveSpec> {
        let mut b = *b;
        b.c = self.unwound(a.c, b.c);
        let (m, layer) = (self.machine, self.toolpath.layer_of[g]);
        self.toolpath
            .layer_reader
            .bead_moves(m, a, &b, m.tip_tolerance, layer, cutoff(g - 1))
    }

    /// C value `c` as the machine reaches it from `prev`: the shorter way
    /// round, unless C has a range (configurations then carry their
    /// absolute C).
    pub fn unwound(&self, prev: f64, c: f64) -> f64 {
        match self.winding() {
            Winding::Free => round_angle(prev + wrap(c - prev)),
            Winding::Absolute => c,
        }
    }

    /// How C is counted on this machine.
    pub fn winding(&self) -> Winding {
        if self.machine.c.range.is_some() {
            Winding::Absolute
        } else {
            Winding::Free
        }
    }
}

/// Every whole turn of C that puts `c` inside `[lo, hi]` (degrees).
pub(super) fn windings(c: f64, [lo, hi]: [f64; 2]) -> Vec<f64> {
    let turn = std::f64::consts::TAU;
    let (lo, hi) = (lo.to_radians() - 1e-9, hi.to_radians() + 1e-9);
    let k0 = ((lo - c) / turn).ceil() as i64;
    let k1 = ((hi - c) / turn).floor() as i64;
    (k0..=k1)
        .map(|k| round_angle(c + k as f64 * turn))
        .collect()
}

/// The distance between two part-frame points (mm), as the planner
/// measures beads: by `hypot`, whose last bits the costs, E and the
/// metrics all take.
pub(super) fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2])
}
