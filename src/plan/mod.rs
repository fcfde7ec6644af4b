//! The planner (paper 000, Algorithm 1): from waypoints to the program a
//! machine runs. [`plan`] runs these stages over one [`State`]:
//!
//! 1. **smooth** the orientations per continuous run ([`smooth`]);
//! 2. give **singular** runs their rotary angles ([`singular`]);
//! 3. **columns** (`columns`): every waypoint's candidate configurations
//!    — both IK solutions of its orientation, else variants
//!    ([`candidates`]), asked only when the search takes them, else every
//!    orientation the machine can reach 5° apart; only configurations
//!    inside the tilt, X, Y, Z (and C) ranges are considered. A waypoint
//!    with none is skipped and reported;
//! 4. **graph** (`search`): per section, the cheapest path through the
//!    layered graph ([`graph`], priced by [`cost`]), every node on it
//!    asked and every printing move proven free ([`crate::prove`]); what fails
//!    dies or is blocked and the path is solved again around it, until the
//!    whole path is proven;
//! 5. **extrusion**: layer heights from the surfaces below ([`extrusion`]),
//!    E along the beads (Eq. 1);
//! 6. **program**: every move the machine makes ([`program`]), travels
//!    proven or re-planned;
//! 7. **metrics**: the written program re-checked pose by pose and move by
//!    move, and the input measured by the same rules ([`metrics`]).

pub mod candidates;
mod columns;
pub mod cost;
pub mod extrusion;
pub mod graph;
pub mod layer_reading;
pub mod metrics;
pub mod program;
mod search;
pub mod singular;
pub mod smooth;
pub mod spread;

use crate::collide::{Backend, CollideError};
use crate::kinematics::{ik_angles, orientation, round_written, wrap, Axes, Machine};
use crate::prove::{MoveSpec, Prover};
use crate::scene::{cutoff, Scene};
use crate::toolpath::Toolpath;
use candidates::Sampling;
use cost::{CostModel, Winding};
use extrusion::Height;
use graph::{Blocked, Columns, Path};
use layer_reading::NearestLayer;
use metrics::{Metrics, SegmentStats};
use program::{Assembly, Program, SectionPlan, Stop};
use rayon::prelude::*;
use smooth::Smoothing;
use std::collections::HashSet;
use std::ops::Range;
use std::time::Instant;

/// What can go wrong planning.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A collision backend failed.
    #[error(transparent)]
    Collide(#[from] CollideError),
    /// The scene was built from another toolpath.
    #[error(
        "the scene has {0} waypoints but the toolpath {1}: build the scene from this toolpath"
    )]
    Mismatch(usize, usize),
    /// A bug, not a user error.
    #[error("internal error: {0}")]
    Internal(String),
}

/// Planner settings.
#[derive(Clone, Copy, Debug)]
pub struct PlanOptions {
    /// Orientation smoothing.
    pub smoothing: Smoothing,
    /// Singular region half-angle α (radians), Eq. 6.
    pub alpha: f64,
    /// Variant cone half-angle β (radians).
    pub beta: f64,
    /// Variant generation.
    pub sampling: Sampling,
    /// Initial spacing of the samples proving a move: the distance the tip
    /// moves between two of them (mm).
    pub edge_step: f64,
    /// Consecutive waypoints farther apart than this start a new section (mm).
    pub jump: f64,
    /// Paper 002's interval subsampling: solve every `subsample`-th column
    /// first, then the intervals (1 = exact, the default).
    pub subsample: usize,
    /// Safety margin (mm); `None`: the machine file's.
    pub margin: Option<f64>,
    /// Weight of a second of extruder dwell against a second of machine
    /// time in the graph's costs ([`cost`]).
    pub dwell_weight: f64,
    /// Spacing of the exhaustive orientation search (radians).
    pub exhaustive_step: f64,
    /// Most candidate configurations a column offers the search at a time
    /// (free, or variants not asked yet, which the search asks as it takes them).
    pub max_configs: usize,
    /// How far (radians) an orientation may move so that C can turn no
    /// faster than the extruder allows ([`spread`]); 0 turns it off.
    pub spread_tolerance: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            smoothing: Smoothing::Laplacian { passes: 8 },
            alpha: 4.5f64.to_radians(),
            beta: 45f64.to_radians(),
            sampling: Sampling::Random { k: 24 },
            edge_step: 0.3,
            jump: 5.0,
            subsample: 1,
            margin: None,
            dwell_weight: 10.0,
            exhaustive_step: 5f64.to_radians(),
            max_configs: 16,
            spread_tolerance: 4.5f64.to_radians(),
        }
    }
}

/// Why a waypoint is not visited.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Skip {
    /// Every reachable orientation (5° apart) comes within the margin of
    /// the platform or printed material.
    Residual,
    /// No orientation puts the machine's axes inside their ranges.
    Unreachable,
    /// Nothing to print there: no bead is printed to or from it (it stands
    /// alone between jumps or breaks), so visiting it would only add two
    /// travels.
    Isolated,
}

/// One waypoint of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedWaypoint {
    /// Layer index.
    pub layer: usize,
    /// Printed by the support extruder (a support layer).
    pub support: bool,
    /// Tip position, part frame (mm).
    pub p: [f64; 3],
    /// Planned nozzle direction, part frame (the input's when skipped).
    pub n: [f64; 3],
    /// Machine axes as written (C unwound); the input's when skipped.
    pub axes: Axes,
    /// Extruder position (mm of filament, absolute within the layer).
    pub e: f64,
    /// Layer height used for extrusion (mm).
    pub height: f64,
    /// First visited waypoint of a section (a travel comes before it).
    pub section_start: bool,
    /// Entered through a break (retract, lift, travel, approach) inside a
    /// section.
    pub break_before: bool,
    /// The input orientation collides (within the margin).
    pub was_colliding: bool,
    /// The input orientation lies in the singular region.
    pub was_singular: bool,
    /// The planned orientation lies in the singular region.
    pub singular: bool,
    /// Not visited, and why.
    pub skipped: Option<Skip>,
}

/// A plan and its report.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Waypoints in print order.
    pub waypoints: Vec<PlannedWaypoint>,
    /// The program the machine runs.
    pub program: Program,
    /// Metrics of the input (direct IK).
    pub input: Metrics,
    /// Metrics of the written program.
    pub plan: Metrics,
    /// Seconds and collision queries per stage, in order.
    pub stages: Vec<Stage>,
    /// The input's machine axes (direct IK, C unwound), per waypoint.
    pub input_axes: Vec<Axes>,
    /// The singular region's half-angle used (radians).
    pub alpha: f64,
    /// The safety margin used (mm).
    pub margin: f64,
    /// Things the user should know (skipped waypoints, unproven travels,
    /// machine Z below 0), one line each.
    pub warnings: Vec<String>,
    /// Collision queries answered while planning.
    pub queries: u64,
}

impl Plan {
    /// The waypoints of `layer` (indices into [`Plan::waypoints`]): the
    /// plan lists them as the toolpath does, layer after layer, so they
    /// are one run, found by bisection.
    pub fn layer_waypoints(&self, layer: usize) -> Range<usize> {
        let w = &self.waypoints;
        w.partition_point(|p| p.layer < layer)..w.partition_point(|p| p.layer <= layer)
    }
}

/// What [`plan`] tells its caller as it goes.
#[derive(Clone, Copy, Debug)]
pub enum Progress<'a> {
    /// A stage begins (its name as users read it).
    Stage(&'a str),
    /// Collision queries of the current batch: `done` of `total`.
    Queries {
        /// Answered so far.
        done: u64,
        /// In the batch.
        total: u64,
    },
    /// A stage ended.
    Done(&'a Stage),
}

/// One stage of the planner: its name, wall time and collision queries.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// Name (`columns`, `graph`, …).
    pub name: String,
    /// Wall time (s).
    pub seconds: f64,
    /// Collision queries answered.
    pub queries: u64,
}

/// Does a half-turn about the head axis map the head onto itself? Then the
/// two IK solutions are the same collision query.
pub fn half_turn_symmetric(scene: &Scene) -> bool {
    let v = &scene.head.mesh.vertices;
    let key = |p: [f32; 3]| {
        [
            (p[0] * 1e4).round() as i64,
            (p[1] * 1e4).round() as i64,
            (p[2] * 1e4).round() as i64,
        ]
    };
    let set: HashSet<[i64; 3]> = v.iter().map(|p| key(*p)).collect();
    v.iter().all(|p| set.contains(&key([-p[0], -p[1], p[2]])))
}

/// The head's largest distance from its tip (mm).
pub fn head_reach(scene: &Scene) -> f64 {
    scene
        .head
        .mesh
        .vertices
        .iter()
        .map(|v| (v[0] as f64).hypot(v[1] as f64).hypot(v[2] as f64))
        .fold(0.0, f64::max)
}

/// How much shorter a bead between two written (rounded) positions can be
/// than between the waypoints themselves (mm): 0.0005 mm on each linear axis
/// and 0.0005° on each angle, at both ends, 100 mm from the rotary axes.
const ROUNDING_MM: f64 = 0.004;

/// Columns on either side of a blocked edge that are solved again, tried
/// in turn: a small window first (few new edges to prove), a larger one
/// when routing around the block needs more breaks than the path had.
pub const REPAIR_WINDOWS: [usize; 2] = [4, 32];

/// Merged windows of `w` columns on either side of `cols` (sorted) in a
/// section of `n` columns.
fn windows(cols: &[usize], n: usize, w: usize) -> Vec<Range<usize>> {
    let mut out: Vec<Range<usize>> = Vec::new();
    for &k in cols {
        let r = k.saturating_sub(w)..(k + w).min(n);
        match out.last_mut() {
            Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
            _ => out.push(r),
        }
    }
    out
}

/// Sample spacing of the input's own moves (mm of head motion).
pub const INPUT_STEP: f64 = 2.0;

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2])
}

/// The graph search's bookkeeping per section.
struct Search {
    edges: Vec<Blocked>,
    paths: Vec<Path>,
}

/// The planner's state, filled stage by stage.
struct State<'a> {
    scene: &'a Scene,
    machine: &'a Machine,
    opts: &'a PlanOptions,
    symmetric: bool,
    /// The waypoints as prepared: positions, input and smoothed
    /// directions, layers, runs, the layer reader, the singular runs.
    wp: Prepared,
    /// Candidate configurations per waypoint (as written), and beside
    /// each what is known of it ([`columns`]).
    cols: Vec<Vec<Axes>>,
    nodes: Vec<Vec<columns::Node>>,
    /// Per waypoint: the next of its first round of variants to enter its
    /// window ([`columns::EXHAUSTED`]: none), how often a node its path
    /// took collided, whether any configuration was in the machine's
    /// ranges, and the orientation it is planned around.
    cursor: Vec<u32>,
    misses: Vec<u8>,
    /// Per colliding waypoint: its first-round variants free at a probe
    /// (a probe's own, or those free at both probes around it), and
    /// whether it is a probe ([`columns::PROBE_EVERY`]).
    free_at: Vec<u128>,
    probed: Vec<bool>,
    offered: Vec<bool>,
    centre: Vec<[f64; 3]>,
    skip: Vec<Option<Skip>>,
    /// Runs split at skipped waypoints, and their chosen paths.
    sections: Vec<Range<usize>>,
    paths: Vec<Path>,
    heights: Vec<Height>,
    e: Vec<f64>,
    warnings: Vec<String>,
}

/// Plan `toolpath` (whose scene is `scene`) for `machine`, answering every
/// collision question with `backend`. `progress` hears each stage begin
/// and end, and the progress of every batch of queries.
pub fn plan(
    scene: &Scene,
    toolpath: &Toolpath,
    machine: &Machine,
    backend: &dyn Backend,
    opts: &PlanOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Plan, PlanError> {
    let prepared = Prepared::new(toolpath, machine, opts);
    plan_prepared(prepared, scene, machine, backend, opts, progress)
}

/// [`plan`] from what [`Prepared::new`] made of the toolpath with the
/// same `machine` and `opts` (its stages are reported first, with the
/// seconds they took then).
pub fn plan_prepared(
    mut prepared: Prepared,
    scene: &Scene,
    machine: &Machine,
    backend: &dyn Backend,
    opts: &PlanOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Plan, PlanError> {
    let n_wp = prepared.pos.len();
    if scene.waypoint_queries.len() != n_wp {
        return Err(PlanError::Mismatch(scene.waypoint_queries.len(), n_wp));
    }
    if !prepared.made_with(machine, opts) {
        return Err(PlanError::Internal(
            "the toolpath was prepared with other settings".into(),
        ));
    }
    let margin = opts.margin.unwrap_or(machine.margin);
    let progress = std::sync::Mutex::new(progress);
    let tell = |p: Progress| (progress.lock().expect("progress"))(p);
    let tick = |done, total| tell(Progress::Queries { done, total });
    let prover =
        Prover::new(machine, backend, head_reach(scene), margin, opts.edge_step).with_ticker(&tick);
    let mut stages = Vec::new();
    let mut clock = Instant::now();
    let mut asked = 0;
    let mut lap = |name: &str, stages: &mut Vec<Stage>| {
        release_freed_memory();
        let q = prover.queries();
        let stage = Stage {
            name: name.to_string(),
            seconds: clock.elapsed().as_secs_f64(),
            queries: q - asked,
        };
        tell(Progress::Done(&stage));
        stages.push(stage);
        asked = q;
        clock = Instant::now();
    };
    let prepared_stages = std::mem::take(&mut prepared.stages);
    let mut st = State::new(scene, prepared, machine, opts);
    // The input's own metrics need nothing the planner finds: they are
    // measured beside it, with a prover of their own (its answers and
    // counts do not depend on how the two interleave), and fill the
    // cores the planner's serial steps leave idle.
    let input = InputJob::new(&st);
    let input_prover = Prover::new(machine, backend, head_reach(scene), margin, opts.edge_step);
    for stage in prepared_stages {
        tell(Progress::Done(&stage));
        stages.push(stage);
    }
    let (planned, measured) = rayon::join(
        || -> Result<_, PlanError> {
            tell(Progress::Stage("collisions"));
            st.columns(&prover)?;
            lap("columns", &mut stages);
            tell(Progress::Stage("graph"));
            st.graph(&prover)?;
            lap("graph", &mut stages);
            tell(Progress::Stage("extrusion"));
            st.extrusion();
            lap("extrusion", &mut stages);
            tell(Progress::Stage("program"));
            let program = st.program(&prover)?;
            lap("program", &mut stages);
            tell(Progress::Stage("metrics"));
            let (plan_m, waypoints) = st.plan_metrics(&program, &prover)?;
            lap("verify", &mut stages);
            Ok((program, plan_m, waypoints))
        },
        || {
            let t = Instant::now();
            let m = input.metrics(&input_prover);
            (m, t.elapsed().as_secs_f64())
        },
    );
    let (program, plan_m, waypoints) = planned?;
    let ((input_m, input_axes, was_colliding), input_s) = (measured.0?, measured.1);
    let stage = Stage {
        name: "input".into(),
        seconds: input_s,
        queries: input_prover.queries(),
    };
    tell(Progress::Done(&stage));
    stages.push(stage);
    let waypoints = waypoints
        .into_iter()
        .zip(&input_axes)
        .zip(was_colliding)
        .map(|((mut w, ia), wc)| {
            w.was_colliding = wc;
            if w.skipped.is_some() {
                w.axes = *ia;
            }
            w
        })
        .collect();
    Ok(Plan {
        waypoints,
        program,
        input: input_m,
        plan: plan_m,
        stages,
        input_axes,
        alpha: opts.alpha,
        margin,
        warnings: st.warnings,
        queries: prover.queries() + input_prover.queries(),
    })
}

/// Hand memory freed by the planner's temporaries back to the OS when
/// the allocator holds more than [`RETAINED_AT_MOST`] of it. glibc's
/// malloc keeps freed memory mapped: each worker thread has its own
/// arena, and the holes freed among long-lived allocations (the columns'
/// vectors, the prover's caches) are never trimmed from the top. On the
/// 700 k-waypoint stand-in tilted 50° (BENCHMARKS.md) the columns' own
/// 0.9 GiB stayed mapped through the program stage, the plan's peak;
/// `malloc_trim` returns every wholly free page of every arena (80 ms
/// there). Small amounts are left alone: trimmed pages cost a page fault
/// each when they are used again (dome_cut, which frees 100–270 MiB
/// between stages, spent 0.36 s more system time trimming at every
/// stage). Elsewhere than glibc, nothing to do.
fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallinfo reads the allocator's statistics and malloc_trim
    // returns free pages to the kernel; both take the allocator's locks
    // like any malloc call and touch no memory in use.
    unsafe {
        // `mallinfo`, not `mallinfo2`: that needs glibc 2.33, and
        // distributions still in service ship older ones. Its `int` field
        // holds the low 32 bits of the count, exact below 4 GiB freed;
        // beyond, a wrapped count at worst skips one trim.
        let freed = libc::mallinfo().fordblks as u32 as usize;
        if freed > RETAINED_AT_MOST {
            libc::malloc_trim(0);
        }
    }
}

/// Freed memory (bytes) the allocator may keep mapped between stages
/// ([`release_freed_memory`]).
const RETAINED_AT_MOST: usize = 512 << 20;

/// What the planner makes of the toolpath alone, before any collision
/// question: the waypoints flattened into continuous runs, the index of
/// which layer a point reads as, the smoothed orientations (stage 1) and
/// the singular runs' angles (stage 2). It needs no scene, so a caller
/// can make it while the scene is built ([`crate::job::LoadedJob::load_beside`]);
/// [`plan`] makes it first.
pub struct Prepared {
    /// Tip positions, input and smoothed directions, layer of each waypoint.
    pos: Vec<[f64; 3]>,
    n0: Vec<[f64; 3]>,
    n1: Vec<[f64; 3]>,
    layer_of: Vec<usize>,
    /// Which layer a tip position reads as (split points of beads are
    /// placed where they read as their own layer).
    reader: NearestLayer,
    /// Per layer: support layer? global index of its first waypoint.
    support: Vec<bool>,
    layer_start: Vec<usize>,
    /// Continuous runs (a layer, split at jumps).
    runs: Vec<Range<usize>>,
    /// Singular-run angles, and whether the input orientation is singular.
    fixed: Vec<Option<(f64, f64)>>,
    was_singular: Vec<bool>,
    /// What it was made with ([`Prepared::made_with`]).
    made: (Smoothing, f64, f64, crate::kinematics::Rotary),
    /// Its stages, as they ran.
    stages: Vec<Stage>,
}

impl Prepared {
    /// Flatten `toolpath` into continuous runs and run stages 1 and 2 for
    /// `machine` with `opts`.
    pub fn new(toolpath: &Toolpath, machine: &Machine, opts: &PlanOptions) -> Self {
        let n_wp = toolpath.waypoint_count();
        let mut pos = Vec::with_capacity(n_wp);
        let mut n0 = Vec::with_capacity(n_wp);
        let mut layer_of = Vec::with_capacity(n_wp);
        for (k, w) in toolpath.iter() {
            pos.push(w.pos.map(|x| x as f64));
            let d = w.dir.map(|x| x as f64);
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            n0.push(d.map(|x| x / l));
            layer_of.push(k);
        }
        let runs = runs(toolpath, opts.jump);
        let was_singular = n0
            .iter()
            .map(|n| singular::is_singular(*n, opts.alpha))
            .collect();
        let mut p = Prepared {
            n1: n0.clone(),
            reader: NearestLayer::new(&pos, &layer_of),
            pos,
            n0,
            layer_of,
            support: toolpath.layers.iter().map(|l| l.is_support()).collect(),
            layer_start: toolpath.layer_offsets(),
            runs,
            fixed: vec![None; n_wp],
            was_singular,
            made: (opts.smoothing, opts.alpha, opts.jump, machine.rotary),
            stages: Vec::new(),
        };
        let clock = Instant::now();
        p.smooth(opts.smoothing);
        p.stages.push(Stage {
            name: "smooth".into(),
            seconds: clock.elapsed().as_secs_f64(),
            queries: 0,
        });
        let clock = Instant::now();
        p.singularities(machine.rotary, opts.alpha);
        p.stages.push(Stage {
            name: "singularities".into(),
            seconds: clock.elapsed().as_secs_f64(),
            queries: 0,
        });
        p
    }

    /// Was it made for `machine` with `opts` (what stages 1 and 2 read)?
    fn made_with(&self, machine: &Machine, opts: &PlanOptions) -> bool {
        self.made == (opts.smoothing, opts.alpha, opts.jump, machine.rotary)
    }

    /// Stage 1: smoothing, run by run.
    fn smooth(&mut self, how: Smoothing) {
        for r in &self.runs {
            let s = smooth::smooth(&self.n0[r.clone()], how);
            self.n1[r.clone()].copy_from_slice(&s);
        }
    }

    /// Stage 2: singular runs get angles from their anchors.
    fn singularities(&mut self, rot: crate::kinematics::Rotary, alpha: f64) {
        for r in &self.runs {
            let (f, _) = singular::process(rot, &self.n1[r.clone()], alpha);
            self.fixed[r.clone()].clone_from_slice(&f);
        }
    }
}

impl<'a> State<'a> {
    /// The planner's state over `scene`, from the prepared toolpath.
    fn new(scene: &'a Scene, p: Prepared, machine: &'a Machine, opts: &'a PlanOptions) -> Self {
        let n_wp = p.pos.len();
        State {
            scene,
            machine,
            opts,
            symmetric: half_turn_symmetric(scene),
            wp: p,
            cols: vec![Vec::new(); n_wp],
            nodes: vec![Vec::new(); n_wp],
            cursor: vec![columns::EXHAUSTED; n_wp],
            misses: vec![0; n_wp],
            free_at: vec![u128::MAX; n_wp],
            probed: vec![false; n_wp],
            offered: vec![false; n_wp],
            centre: Vec::new(),
            skip: vec![None; n_wp],
            sections: Vec::new(),
            paths: Vec::new(),
            heights: Vec::new(),
            e: vec![0.0; n_wp],
            warnings: Vec::new(),
        }
    }

    /// The axes of `(tilt, c)` at waypoint `g`, when every axis is within
    /// the machine's ranges (C: some whole turn of it).
    fn feasible(&self, g: usize, tc: (f64, f64)) -> Option<Axes> {
        let m = self.machine;
        let a = m.axes_at(self.wp.pos[g], tc);
        let t = a.tilt.to_degrees();
        let inside = |v: f64, l: &crate::kinematics::AxisLimits| v >= l.min && v <= l.max;
        let ok = t >= m.tilt.min - 1e-9
            && t <= m.tilt.max + 1e-9
            && inside(a.xyz[0], &m.x)
            && inside(a.xyz[1], &m.y)
            && inside(a.xyz[2], &m.z)
            && m.c.range.is_none_or(|r| !windings(a.c, r).is_empty());
        ok.then_some(a)
    }

    fn cost_model(&self, layer: usize) -> CostModel {
        let t = self.machine.tool_for(self.wp.support[layer]);
        CostModel::new(self.machine, t.feed, t.tip_speed, self.opts.dwell_weight)
    }

    /// The joint-linear moves that print the bead from waypoint `g − 1` at
    /// `a` to `g` at `b`, as the program will write them.
    fn print_moves(&self, g: usize, a: &Axes, b: &Axes) -> Vec<MoveSpec> {
        let mut b = *b;
        b.c = self.unwound(a.c, b.c);
        let (m, layer) = (self.machine, self.wp.layer_of[g]);
        self.wp
            .reader
            .bead_moves(m, a, &b, m.tip_tolerance, layer, cutoff(g - 1))
    }

    fn unwound(&self, prev: f64, c: f64) -> f64 {
        match self.winding() {
            Winding::Free => crate::kinematics::round_angle(prev + wrap(c - prev)),
            Winding::Absolute => c,
        }
    }

    fn winding(&self) -> Winding {
        if self.machine.c.range.is_some() {
            Winding::Absolute
        } else {
            Winding::Free
        }
    }

    /// Stage 5: layer heights and E along the printed beads.
    fn extrusion(&mut self) {
        let ex = &self.machine.extrusion;
        let d = ex.default_height;
        self.heights = extrusion::layer_heights(
            self.scene,
            &self.wp.pos,
            &self.wp.layer_of,
            &self.wp.layer_start,
            [0.05 * d, 4.0 * d],
        );
        let mut e = 0.0;
        let mut layer = usize::MAX;
        for (s, r) in self.sections.iter().enumerate() {
            let tool = self
                .machine
                .tool_for(self.wp.support[self.wp.layer_of[r.start]]);
            for (k, g) in r.clone().enumerate() {
                if self.wp.layer_of[g] != layer {
                    layer = self.wp.layer_of[g];
                    e = 0.0;
                } else if k > 0 && !self.paths[s].breaks[k] {
                    let h = 0.5 * (self.heights[g - 1].h + self.heights[g].h);
                    e += tool.extrusion
                        * ex.k
                        * h
                        * ex.width
                        * dist(self.wp.pos[g - 1], self.wp.pos[g]);
                }
                self.e[g] = round_written(e);
            }
        }
    }

    /// Stage 6: the program, every travel proven or re-planned. Stops
    /// with no printed bead on either side are not visited.
    fn program(&mut self, prover: &Prover) -> Result<Program, PlanError> {
        for (r, p) in self.sections.iter().zip(&self.paths) {
            for (k, g) in r.clone().enumerate() {
                let bead_in = k > 0 && !p.breaks[k];
                let bead_out = k + 1 < r.len() && !p.breaks[k + 1];
                if !bead_in && !bead_out {
                    self.skip[g] = Some(Skip::Isolated);
                }
            }
        }
        let sections: Vec<SectionPlan> = self
            .sections
            .iter()
            .zip(&self.paths)
            .map(|(r, p)| SectionPlan {
                layer: self.wp.layer_of[r.start],
                tool: self
                    .machine
                    .tool_for(self.wp.support[self.wp.layer_of[r.start]]),
                stops: r
                    .clone()
                    .enumerate()
                    .filter(|&(_, g)| self.skip[g].is_none())
                    .map(|(k, g)| Stop {
                        g,
                        axes: self.cols[g][p.nodes[k]],
                        e: self.e[g],
                        brk: p.breaks[k],
                    })
                    .collect(),
            })
            .collect();
        // The columns are read for the last time above: their
        // configurations (most of the planner's memory on a colliding
        // toolpath, a dozen unchecked variants and more per colliding
        // waypoint) go before the program's moves are made.
        self.drop_columns();
        let asm = Assembly {
            machine: self.machine,
            tip_tolerance: self.machine.tip_tolerance,
            sphere_z: self.sphere_z(prover.margin),
            reader: &self.wp.reader,
        };
        let (program, stuck) = asm.build(&sections, prover)?;
        if !stuck.is_empty() {
            self.warnings.push(format!(
                "{} move group(s) of the program could not be proven free even at the highest travel: see colliding_edges",
                stuck.len()
            ));
        }
        Ok(program)
    }

    /// Machine Z above which no rotation of the part can reach the head
    /// (configuration III: the part turns about the origin; the head hangs
    /// above its tip).
    fn sphere_z(&self, margin: f64) -> f64 {
        // The farthest vertex from the origin, by its squared distance
        // (exact for f32 coordinates but for the sum's rounding; `hypot`
        // took 0.1 s on dome_cut's 2.2 M triangles).
        let r2 = self
            .scene
            .part_tris
            .par_iter()
            .map(|t| {
                [t.v0, t.v1, t.v2]
                    .iter()
                    .map(|v| v.iter().map(|&x| (x as f64) * (x as f64)).sum::<f64>())
                    .fold(0.0, f64::max)
            })
            .reduce(|| 0.0, f64::max);
        let r = r2.sqrt();
        let below = -(self.scene.head.params.aabb_min[2] as f64).min(0.0);
        r + margin + below + 1.0
    }

    /// Stage 7a: the written program re-checked, and the plan's figures.
    fn plan_metrics(
        &mut self,
        program: &Program,
        prover: &Prover,
    ) -> Result<(Metrics, Vec<PlannedWaypoint>), PlanError> {
        let m = self.machine;
        let moves = program.moves(m);
        // Where the program puts each visited waypoint.
        let n = self.wp.pos.len();
        let mut at: Vec<Option<Axes>> = vec![None; n];
        for (_, mv) in &moves {
            if let Some(g) = mv.waypoint {
                at[g] = Some(mv.to);
            }
        }
        // What needs the moves themselves first; the checks below need
        // only their specs, so the moves (136 bytes each) are let go
        // before the prover's own work.
        let dev = largest_tip_deviation(m, &moves);
        let mut travel_c: f64 = 0.0;
        let mut run_c = 0.0;
        let mut axis_limit_violations = 0;
        for (from, mv) in &moves {
            if mv.kind.extrudes() {
                travel_c = travel_c.max(run_c);
                run_c = 0.0;
            } else {
                run_c += (mv.to.c - from.c).abs().to_degrees();
            }
            if metrics::outside_limits(m, &mv.to) {
                axis_limit_violations += 1;
            }
        }
        let specs: Vec<MoveSpec> = moves
            .iter()
            .filter(|(from, mv)| *from != mv.to)
            .map(|(from, mv)| MoveSpec {
                from: *from,
                to: mv.to,
                cutoff: mv.cutoff,
            })
            .collect();
        drop(moves);
        let visited: Vec<(Axes, u32)> = (0..n)
            .filter_map(|g| at[g].map(|a| (a, cutoff(g))))
            .collect();
        let pose_hits = prover.poses_at(&visited, prover.margin)?;
        let move_hits = prover.moves(&specs)?;

        let mut out = Metrics {
            waypoints: n,
            residual_collisions: pose_hits.iter().filter(|&&h| h).count(),
            colliding_edges: move_hits.iter().filter(|&&h| h).count(),
            program_moves: specs.len(),
            axis_limit_violations,
            ..Metrics::default()
        };
        // Segments printed between consecutive visited waypoints.
        let mut stats = SegmentStats::default();
        let mut clamped = 0usize;
        let mut segments = 0usize;
        for (s, r) in self.sections.iter().enumerate() {
            let tool = m.tool_for(self.wp.support[self.wp.layer_of[r.start]]);
            let cm = CostModel::new(m, tool.feed, tool.tip_speed, self.opts.dwell_weight);
            for (k, g) in r.clone().enumerate().skip(1) {
                if self.paths[s].breaks[k] {
                    continue;
                }
                let (a, b) = (at[g - 1].expect("visited"), at[g].expect("visited"));
                // The bead as written: between the tips the axes give.
                let len = dist(m.tip(&a), m.tip(&b));
                stats.add(&cm, len, &a, &b);
                segments += 1;
                clamped += (self.heights[g - 1].clamped || self.heights[g].clamped) as usize;
            }
        }
        stats.finish(&mut out);
        out.height_clamped_pct = 100.0 * clamped as f64 / segments.max(1) as f64;
        // Tip deviation and travel rotation of the written moves.
        out.tip_deviation_max_mm = dev;
        out.travel_c_max_deg = travel_c.max(run_c);
        out.breaks = self
            .paths
            .iter()
            .map(|p| p.breaks.iter().filter(|&&b| b).count())
            .sum();
        let skipped: Vec<usize> = (0..n).filter(|&g| self.skip[g].is_some()).collect();
        out.skipped_waypoints = skipped.len();
        let count = |why: Skip| {
            skipped
                .iter()
                .filter(|&&g| self.skip[g] == Some(why))
                .count()
        };
        out.unreachable_waypoints = count(Skip::Unreachable);
        out.isolated_waypoints = count(Skip::Isolated);

        // Per waypoint.
        let mut section_start = vec![false; n];
        let mut brk = vec![false; n];
        for (s, r) in self.sections.iter().enumerate() {
            if let Some(g) = r.clone().find(|&g| self.skip[g].is_none()) {
                section_start[g] = true;
            }
            for (k, g) in r.clone().enumerate() {
                brk[g] = self.paths[s].breaks[k] && !section_start[g];
            }
        }
        let rot = m.rotary;
        let wps: Vec<PlannedWaypoint> = (0..n)
            .map(|g| {
                let (axes, nn) = match at[g] {
                    Some(a) => (a, orientation(rot, a.tilt, a.c)),
                    None => (Axes::default(), self.wp.n0[g]),
                };
                PlannedWaypoint {
                    layer: self.wp.layer_of[g],
                    support: self.wp.support[self.wp.layer_of[g]],
                    p: self.wp.pos[g],
                    n: nn,
                    axes,
                    e: self.e[g],
                    height: self.heights[g].h,
                    section_start: section_start[g],
                    break_before: brk[g],
                    was_colliding: false,
                    was_singular: self.wp.was_singular[g],
                    singular: at[g].is_some() && singular::is_singular(nn, self.opts.alpha),
                    skipped: self.skip[g],
                }
            })
            .collect();
        out.singular_waypoints = wps.iter().filter(|w| w.singular).count();
        let dev: Vec<f64> = wps
            .iter()
            .zip(&self.wp.n0)
            .filter(|(w, _)| w.skipped.is_none())
            .map(|(w, n)| {
                (w.n[0] * n[0] + w.n[1] * n[1] + w.n[2] * n[2])
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees()
            })
            .collect();
        out.max_deviation_deg = dev.iter().copied().fold(0.0, f64::max);
        out.mean_deviation_deg = dev.iter().sum::<f64>() / dev.len().max(1) as f64;

        // Warnings a user must see (the first few skipped waypoints by
        // name; report.json and plan.csv list them all).
        let unsafe_skips: Vec<usize> = skipped
            .iter()
            .copied()
            .filter(|&g| self.skip[g] != Some(Skip::Isolated))
            .collect();
        for &g in unsafe_skips.iter().take(20) {
            let l = self.wp.layer_of[g];
            let why = match self.skip[g] {
                Some(Skip::Unreachable) => "outside the machine's axis ranges in every orientation",
                _ => "no orientation the machine can reach keeps the safety margin",
            };
            self.warnings.push(format!(
                "waypoint {g} (layer {l}, #{} in it) skipped: {why}",
                g - self.wp.layer_start[l]
            ));
        }
        if unsafe_skips.len() > 20 {
            self.warnings.push(format!(
                "{} more waypoints skipped (listed in report.json and plan.csv)",
                unsafe_skips.len() - 20
            ));
        }
        if out.isolated_waypoints > 0 {
            self.warnings.push(format!(
                "{} isolated waypoint(s) not visited: no bead is printed to or from them",
                out.isolated_waypoints
            ));
        }
        let below = wps
            .iter()
            .filter(|w| w.skipped.is_none() && w.axes.xyz[2] < 0.0)
            .count();
        if below > 0 {
            self.warnings.push(format!(
                "{below} waypoint(s) put machine Z below 0: check --place and the machine's Z origin"
            ));
        }
        if out.colliding_edges > 0 {
            self.warnings.push(format!(
                "{} move(s) of the program could not be proven to keep the {:.3} mm margin",
                out.colliding_edges, prover.margin
            ));
        }
        Ok((out, wps))
    }
}

/// Stage 7b: the input as given, measured by the same rules as the plan
/// (direct IK, C unwound, orientations unchanged) — what it needs of the
/// toolpath, copied so that it runs beside the planner.
struct InputJob<'a> {
    machine: &'a Machine,
    opts: &'a PlanOptions,
    pos: Vec<[f64; 3]>,
    n0: Vec<[f64; 3]>,
    layer_of: Vec<usize>,
    support: Vec<bool>,
    runs: Vec<Range<usize>>,
    /// Waypoints in the singular region as given.
    singular: usize,
}

impl<'a> InputJob<'a> {
    fn new(st: &State<'a>) -> Self {
        InputJob {
            machine: st.machine,
            opts: st.opts,
            pos: st.wp.pos.clone(),
            n0: st.wp.n0.clone(),
            layer_of: st.wp.layer_of.clone(),
            support: st.wp.support.clone(),
            runs: st.wp.runs.clone(),
            singular: st.wp.was_singular.iter().filter(|&&s| s).count(),
        }
    }

    /// The input's metrics, its axes and which of its poses collide: a
    /// move from or to a pose within the margin collides; the others —
    /// C swings of hundreds of degrees between neighbours, mostly — are
    /// sampled ([`INPUT_STEP`] mm of head motion apart, at most 16
    /// samples), so the colliding-edge count is a lower bound.
    fn metrics(&self, prover: &Prover) -> Result<(Metrics, Vec<Axes>, Vec<bool>), PlanError> {
        let m = self.machine;
        let axes = input_axes(m, &self.pos, &self.n0, &self.runs);
        let items: Vec<(Axes, u32)> = axes
            .iter()
            .enumerate()
            .map(|(g, a)| (*a, cutoff(g)))
            .collect();
        let hit = prover.poses_at(&items, prover.margin)?;
        let edges: Vec<usize> = self.runs.iter().flat_map(|r| r.start + 1..r.end).collect();
        let specs: Vec<MoveSpec> = edges
            .iter()
            .filter(|&&g| !hit[g - 1] && !hit[g])
            .map(|&g| MoveSpec {
                from: axes[g - 1],
                to: axes[g],
                cutoff: cutoff(g - 1),
            })
            .collect();
        let sampled = prover.sampled_moves(&specs, INPUT_STEP, 16)?;
        let colliding_edges = edges.len() - specs.len() + sampled.iter().filter(|&&h| h).count();
        let mut out = Metrics {
            waypoints: self.pos.len(),
            residual_collisions: hit.iter().filter(|&&h| h).count(),
            colliding_edges,
            singular_waypoints: self.singular,
            ..Metrics::default()
        };
        let mut stats = SegmentStats::default();
        for r in &self.runs {
            let tool = m.tool_for(self.support[self.layer_of[r.start]]);
            let cm = CostModel::new(m, tool.feed, tool.tip_speed, self.opts.dwell_weight);
            for g in r.start + 1..r.end {
                stats.add(
                    &cm,
                    dist(self.pos[g - 1], self.pos[g]),
                    &axes[g - 1],
                    &axes[g],
                );
            }
        }
        stats.finish(&mut out);
        out.axis_limit_violations = axes
            .iter()
            .filter(|a| metrics::outside_limits(m, a))
            .count();
        Ok((out, axes, hit))
    }
}

/// The largest tip deviation of the extruding moves (sampled as a
/// controller interpolates, [`metrics::tip_deviation`]: 63 poses a move).
/// No move deviates more than its analytic bound
/// ([`crate::prove::tip_deviation_bound`]), so moves are sampled in order of
/// their bounds, largest first, in parallel blocks, until no bound left
/// can beat the largest found: the same maximum as sampling every move.
fn largest_tip_deviation(m: &Machine, moves: &[(Axes, program::Move)]) -> f64 {
    largest_tip_deviation_in(m, moves, 4096)
}

/// [`largest_tip_deviation`], sampling `block` moves at a time.
fn largest_tip_deviation_in(m: &Machine, moves: &[(Axes, program::Move)], block: usize) -> f64 {
    let mut bounded: Vec<(f64, usize)> = moves
        .par_iter()
        .enumerate()
        .filter(|(_, (_, mv))| mv.kind.extrudes())
        .map(|(i, (from, mv))| (crate::prove::tip_deviation_bound(m, from, &mv.to), i))
        .collect();
    bounded.par_sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut best: f64 = 0.0;
    for block in bounded.chunks(block) {
        // (Rounding: a bound is compared with a little to spare.)
        if block[0].0 * (1.0 + 1e-9) + 1e-12 < best {
            break;
        }
        best = block
            .par_iter()
            .map(|&(_, i)| metrics::tip_deviation(m, &moves[i].0, &moves[i].1.to))
            .reduce(|| best, f64::max);
    }
    best
}

/// Every whole turn of C that puts `c` inside `[lo, hi]` (degrees).
fn windings(c: f64, [lo, hi]: [f64; 2]) -> Vec<f64> {
    let turn = std::f64::consts::TAU;
    let (lo, hi) = (lo.to_radians() - 1e-9, hi.to_radians() + 1e-9);
    let k0 = ((lo - c) / turn).ceil() as i64;
    let k1 = ((hi - c) / turn).floor() as i64;
    (k0..=k1)
        .map(|k| crate::kinematics::round_angle(c + k as f64 * turn))
        .collect()
}

/// Direct IK of the input, as written: per waypoint the solution closest
/// to the previous one (the first: the smaller |C|), C unwound along each
/// run. This is how `check` poses the head too.
pub fn input_axes(
    m: &Machine,
    pos: &[[f64; 3]],
    n: &[[f64; 3]],
    runs: &[Range<usize>],
) -> Vec<Axes> {
    let rot = m.rotary;
    let mut out = vec![Axes::default(); pos.len()];
    for r in runs {
        let mut prev: Option<(f64, f64)> = None;
        for i in r.clone() {
            let s = ik_angles(rot, n[i]);
            let pick = match prev {
                None => {
                    if s[1].1.abs() < s[0].1.abs() {
                        s[1]
                    } else {
                        s[0]
                    }
                }
                Some((pt, pc)) => {
                    let cost = |x: (f64, f64)| (x.0 - pt).abs() + wrap(x.1 - pc).abs();
                    let best = if cost(s[1]) < cost(s[0]) { s[1] } else { s[0] };
                    (best.0, pc + wrap(best.1 - pc))
                }
            };
            out[i] = m.axes_at(pos[i], pick);
            prev = Some((out[i].tilt, out[i].c));
        }
    }
    out
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

#[cfg(test)]
mod tests {
    use super::program::{Move, MoveKind};
    use super::*;

    /// A toolpath prepared on its own (as `plan` prepares it beside the
    /// scene's build) plans as [`plan`] plans it; one prepared with other
    /// settings is refused instead of planned with the wrong orientations.
    #[test]
    fn a_prepared_toolpath_plans_as_plan_does() {
        let job = crate::default_job::job();
        let scene = crate::default_job::scene();
        let m = Machine::default();
        let backend = crate::collide::cpu::CpuBackend::new(&scene);
        let opts = PlanOptions::default();
        let whole = plan(&scene, &job.toolpath, &m, &backend, &opts, &mut |_| {}).unwrap();
        let prepared = Prepared::new(&job.toolpath, &m, &opts);
        let apart = plan_prepared(prepared, &scene, &m, &backend, &opts, &mut |_| {}).unwrap();
        assert!(whole.program == apart.program);
        let names = |p: &Plan| -> Vec<String> { p.stages.iter().map(|s| s.name.clone()).collect() };
        assert_eq!(names(&whole), names(&apart));
        assert_eq!(names(&apart)[..2], ["smooth", "singularities"]);

        let other = PlanOptions {
            smoothing: Smoothing::None,
            ..opts
        };
        let prepared = Prepared::new(&job.toolpath, &m, &other);
        let refused = plan_prepared(prepared, &scene, &m, &backend, &opts, &mut |_| {});
        assert!(matches!(refused, Err(PlanError::Internal(_))));
    }

    /// The pruned search finds what sampling every extruding move finds,
    /// and ignores moves that do not extrude however far they bow.
    #[test]
    fn the_largest_tip_deviation_matches_sampling_every_move() {
        let m = Machine::default();
        let mut h = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut moves = Vec::new();
        for k in 0..20_000 {
            let p = [
                rnd() * 100.0 - 50.0,
                rnd() * 100.0 - 50.0,
                40.0 + rnd() * 30.0,
            ];
            let (t, c) = ((rnd() * 90.0 - 45.0).to_radians(), rnd() * 6.0);
            let from = m.axes_at(p, (t, c));
            let kind = if k % 10 == 0 {
                MoveKind::Travel
            } else {
                MoveKind::Print
            };
            // Travels turn far; beads a little, some more than others.
            let turn = if kind == MoveKind::Travel {
                2.0
            } else {
                rnd().powi(4) * 0.3
            };
            let q = [p[0] + rnd() - 0.5, p[1] + rnd() - 0.5, p[2] + 0.1 * rnd()];
            let to = m.axes_at(q, (t + 0.3 * turn, c + turn));
            let mv = Move {
                kind,
                to,
                e: 0.0,
                feed: 10.0,
                cutoff: 1,
                waypoint: None,
                offset: [0.0; 2],
            };
            moves.push((from, mv));
        }
        let plain = moves
            .iter()
            .filter(|(_, mv)| mv.kind.extrudes())
            .map(|(from, mv)| metrics::tip_deviation(&m, from, &mv.to))
            .fold(0.0, f64::max);
        let all = moves
            .iter()
            .map(|(from, mv)| metrics::tip_deviation(&m, from, &mv.to))
            .fold(0.0, f64::max);
        assert!(plain > 0.0 && all > plain);
        for block in [1, 7, 4096] {
            assert_eq!(largest_tip_deviation_in(&m, &moves, block), plain);
        }
    }
}
