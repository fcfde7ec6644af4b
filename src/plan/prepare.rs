//! Stages 1 and 2, which need no scene: the toolpath flattened into
//! continuous runs, its orientations smoothed ([`super::smooth`]) and its
//! singular runs given their rotary angles ([`super::singular`]), so that a
//! caller can prepare it while the scene is built.

use super::layer_reading::NearestLayer;
use super::smooth::{self, Smoothing};
use super::{singular, PlanOptions, Stage, StageName};
use crate::kinematics::{Machine, Rotary};
use crate::toolpath::Toolpath;
use glam::Vec3;
use std::ops::Range;
use std::time::Instant;

/// What the planner makes of the toolpath alone, before any collision
/// question: the waypoints flattened into continuous runs, the index of
/// which layer a point reads as, the smoothed orientations (stage 1) and
/// the singular runs' angles (stage 2). It needs no scene, so a caller
/// can make it while the scene is built ([`crate::job::LoadedJob::load_beside`]);
/// [`super::plan`] makes it first.
pub struct Prepared {
    /// Tip position of each waypoint (part frame, mm).
    pub(super) pos: Vec<[f64; 3]>,
    /// Each waypoint's nozzle direction as given, normalised.
    pub(super) input_dirs: Vec<[f64; 3]>,
    /// Each waypoint's direction after stage 1's smoothing.
    pub(super) smoothed_dirs: Vec<[f64; 3]>,
    /// Each waypoint's layer.
    pub(super) layer_of: Vec<usize>,
    /// Which layer a tip position reads as (split points of beads are
    /// placed where they read as their own layer).
    pub(super) layer_reader: NearestLayer,
    /// Per layer: printed by the support extruder?
    pub(super) layer_is_support: Vec<bool>,
    /// Per layer: the global index of its first waypoint.
    pub(super) layer_start: Vec<usize>,
    /// Continuous runs (a layer, split at jumps).
    pub(super) runs: Vec<Range<usize>>,
    /// Per waypoint in a singular run: the `(tilt, c)` stage 2 gave it.
    pub(super) singular_angles: Vec<Option<(f64, f64)>>,
    /// Per waypoint: its direction as given lies in the singular region.
    pub(super) was_singular: Vec<bool>,
    /// The settings stages 1 and 2 read ([`Prepared::was_made_for`]).
    made_for: PreparedFor,
    /// Its stages, as they ran.
    pub(super) stages: Vec<Stage>,
}

/// What stages 1 and 2 read of the machine and the planner's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PreparedFor {
    smoothing: Smoothing,
    alpha: f64,
    jump: f64,
    rotary: Rotary,
}

impl PreparedFor {
    fn new(machine: &Machine, opts: &PlanOptions) -> Self {
        PreparedFor {
            smoothing: opts.smoothing,
            alpha: opts.alpha,
            jump: opts.jump,
            rotary: machine.rotary,
        }
    }
}

impl Prepared {
    /// Flatten `toolpath` into continuous runs and run stages 1 and 2 for
    /// `machine` with `opts`.
    pub fn new(toolpath: &Toolpath, machine: &Machine, opts: &PlanOptions) -> Self {
        let n_wp = toolpath.waypoint_count();
        let mut pos = Vec::with_capacity(n_wp);
        let mut input_dirs = Vec::with_capacity(n_wp);
        let mut layer_of = Vec::with_capacity(n_wp);
        for (k, w) in toolpath.iter() {
            pos.push(w.pos.map(|x| x as f64));
            let d = Vec3::from(w.dir).as_dvec3();
            input_dirs.push((d / d.length()).to_array());
            layer_of.push(k);
        }
        let runs = runs(toolpath, opts.jump);
        let was_singular = input_dirs
            .iter()
            .map(|n| singular::is_singular(*n, opts.alpha))
            .collect();
        let mut p = Prepared {
            smoothed_dirs: input_dirs.clone(),
            layer_reader: NearestLayer::new(&pos, &layer_of),
            pos,
            input_dirs,
            layer_of,
            layer_is_support: toolpath.layers.iter().map(|l| l.is_support()).collect(),
            layer_start: toolpath.layer_offsets(),
            runs,
            singular_angles: vec![None; n_wp],
            was_singular,
            made_for: PreparedFor::new(machine, opts),
            stages: Vec::new(),
        };
        p.timed(StageName::Smooth, |p| p.smooth(opts.smoothing));
        p.timed(StageName::Singularities, |p| {
            p.singularities(machine.rotary, opts.alpha)
        });
        p
    }

    /// Was it made for `machine` with `opts` (what stages 1 and 2 read)?
    pub(super) fn was_made_for(&self, machine: &Machine, opts: &PlanOptions) -> bool {
        self.made_for == PreparedFor::new(machine, opts)
    }

    /// Run stage `name` and keep its record.
    fn timed(&mut self, name: StageName, stage: impl FnOnce(&mut Self)) {
        let clock = Instant::now();
        stage(self);
        self.stages.push(Stage {
            name: name.as_str().into(),
            seconds: clock.elapsed().as_secs_f64(),
            queries: 0,
            answering: Default::default(),
        });
    }

    /// Stage 1: smoothing, run by run.
    fn smooth(&mut self, how: Smoothing) {
        for r in &self.runs {
            let s = smooth::smooth(&self.input_dirs[r.clone()], how);
            self.smoothed_dirs[r.clone()].copy_from_slice(&s);
        }
    }

    /// Stage 2: singular runs get angles from their anchors.
    fn singularities(&mut self, rot: Rotary, alpha: f64) {
        for r in &self.runs {
            let (angles, _) = singular::process(rot, &self.smoothed_dirs[r.clone()], alpha);
            self.singular_angles[r.clone()].clone_from_slice(&angles);
        }
    }
}

/// The continuous runs of a toolpath: its layers, split where consecutive
/// waypoints are more than `jump` mm apart.
pub fn runs(toolpath: &Toolpath, jump: f64) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut g = 0;
    for layer in &toolpath.layers {
        let mut start = g;
        for (k, w) in layer.waypoints.iter().enumerate() {
            if k > 0 {
                let q = layer.waypoints[k - 1].pos;
                let d = ((w.pos[0] - q[0]) as f64)
                    .hypot((w.pos[1] - q[1]) as f64)
                    .hypot((w.pos[2] - q[2]) as f64);
                if d > jump {
                    out.push(start..g);
                    start = g;
                }
            }
            g += 1;
        }
        if start < g {
            out.push(start..g);
        }
    }
    out
}
