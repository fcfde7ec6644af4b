//! The planner (paper 000, Algorithm 1): from waypoints to the program a
//! machine runs. [`plan`] runs these stages ([`StageName`]), each in the
//! file that bears its name, each over what the stage before hands it:
//!
//! 1. **smooth** the orientations per continuous run ([`smooth`]);
//! 2. give **singular** runs their rotary angles ([`singular`]) — these
//!    two need no scene: they make the [`Prepared`] toolpath (`prepare`);
//! 3. **columns** (`columns`): every waypoint's candidate configurations
//!    — both IK solutions of its orientation, else variants
//!    ([`candidates`]), asked only when the search takes them, else every
//!    orientation the machine can reach 5° apart; only configurations
//!    inside the tilt, X, Y, Z (and C) ranges are considered. A waypoint
//!    with none is skipped and reported;
//! 4. **graph** (`graph`): per section, the cheapest path through the
//!    layered graph ([`shortest_path`], priced by [`cost`]), every node on
//!    it asked and every printing move proven free ([`crate::prove`]); what
//!    fails dies or is blocked and the path is solved again around it,
//!    until the whole path is proven; turns the extruder cannot follow are
//!    spread ([`spread`]);
//! 5. **extrusion**: layer heights from the surfaces below, E along the
//!    beads (Eq. 1) ([`extrusion`]);
//! 6. **program**: every move the machine makes ([`program`]), travels
//!    proven or re-planned;
//! 7. **verify** (`verify`): the written program re-checked pose by pose
//!    and move by move and measured ([`metrics`]); beside the stages,
//!    **input**: the input measured by the same rules.
//!
//! What every stage from 3 on reads (the scene, the machine, the settings,
//! the prepared toolpath) is one `Setup`.

pub mod candidates;
mod columns;
pub mod cost;
pub mod extrusion;
mod graph;
mod idle;
pub mod layer_reading;
pub(crate) mod memory;
pub mod metrics;
mod prepare;
pub mod program;
mod setup;
pub mod shortest_path;
pub mod singular;
pub mod smooth;
pub mod spread;
mod verify;

pub use graph::REPAIR_WINDOWS;
pub use prepare::{runs, Prepared};
pub use verify::{input_axes, INPUT_STEP};

use crate::collide::cpu::CpuBackend;
use crate::collide::{Backend, CollideError};
use crate::kinematics::{Axes, Machine};
use crate::prove::{Answering, Prover};
use crate::scene::Scene;
use crate::toolpath::Toolpath;
use candidates::Sampling;
use memory::release_freed_memory;
use metrics::Metrics;
use program::Program;
use setup::Setup;
use smooth::Smoothing;
use std::collections::HashSet;
use std::ops::Range;
use std::sync::Mutex;
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
            jump: crate::scene::beads::DEFAULT_GAP,
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
    /// A stage begins.
    Stage(StageName),
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

/// The planner's stages, in the order they run. Each has one name
/// ([`StageName::as_str`]): the [`Progress::Stage`] event that begins it
/// and the [`Stage`] record that ends it (report.json's `stages`) both
/// give it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageName {
    /// Stage 1: orientations smoothed per continuous run.
    Smooth,
    /// Stage 2: singular runs given their rotary angles.
    Singularities,
    /// Stage 3: every waypoint's candidate configurations.
    Columns,
    /// Stage 4: per section, the cheapest path proven free.
    Graph,
    /// Stage 5: layer heights and E.
    Extrusion,
    /// Stage 6: every move the machine makes.
    Program,
    /// Stage 7: the written program re-checked and measured.
    Verify,
    /// The input as given, measured by the same rules (beside the others).
    Input,
}

impl StageName {
    /// Every stage, in the order they run.
    pub const ALL: [StageName; 8] = [
        StageName::Smooth,
        StageName::Singularities,
        StageName::Columns,
        StageName::Graph,
        StageName::Extrusion,
        StageName::Program,
        StageName::Verify,
        StageName::Input,
    ];

    /// The stage's name as users read it.
    pub fn as_str(self) -> &'static str {
        match self {
            StageName::Smooth => "smooth",
            StageName::Singularities => "singularities",
            StageName::Columns => "columns",
            StageName::Graph => "graph",
            StageName::Extrusion => "extrusion",
            StageName::Program => "program",
            StageName::Verify => "verify",
            StageName::Input => "input",
        }
    }
}

/// One stage of the planner: its name, wall time and collision queries.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// Name ([`StageName::as_str`]).
    pub name: String,
    /// Wall time (s).
    pub seconds: f64,
    /// Collision queries answered.
    pub queries: u64,
    /// The collision backend's calls and the wall time spent in them:
    /// the evaluator's share of the stage.
    pub answering: Answering,
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
    if !prepared.was_made_for(machine, opts) {
        return Err(PlanError::Internal(
            "the toolpath was prepared with other settings".into(),
        ));
    }
    let margin = opts.margin.unwrap_or(machine.margin);
    let progress = Mutex::new(progress);
    let tell = |p: Progress| (progress.lock().expect("progress"))(p);
    let tick = |done, total| tell(Progress::Queries { done, total });
    let reach = head_reach(scene);
    // Queries that reach far are answered on the CPU beside a backend
    // that answers them slowly (`Backend::wide_above`).
    let cpu = CpuBackend::new(scene);
    let prover = Prover::new(machine, backend, reach, margin, opts.edge_step)
        .with_ticker(&tick)
        .with_wide(&cpu);
    // The input's own metrics need nothing the planner finds: they are
    // measured beside it, with a prover of their own (its answers and
    // counts do not depend on how the two interleave), on threads that
    // take only the cores the planner leaves idle ([`idle`]).
    let input_prover = Prover::new(machine, backend, reach, margin, opts.edge_step).with_wide(&cpu);
    let mut clock = StageClock::new(&tell);
    for stage in std::mem::take(&mut prepared.stages) {
        clock.record(stage);
    }
    let setup = Setup::new(scene, &prepared, machine, opts);
    let (planned, measured) = idle::beside_idle(
        || run_stages(&setup, &prover, &mut clock),
        || {
            let started = Instant::now();
            let input = verify::measure_input(&setup, &input_prover);
            (input, started.elapsed().as_secs_f64())
        },
    );
    let (program, verified) = planned?;
    let (input, input_seconds) = (measured.0?, measured.1);
    clock.record(Stage {
        name: StageName::Input.as_str().into(),
        seconds: input_seconds,
        queries: input_prover.queries(),
        answering: input_prover.answering(),
    });
    Ok(Plan {
        waypoints: verify::with_input(verified.waypoints, &input),
        program,
        input: input.metrics,
        plan: verified.metrics,
        stages: clock.stages,
        input_axes: input.axes,
        alpha: opts.alpha,
        margin,
        warnings: verified.warnings,
        queries: prover.queries() + input_prover.queries(),
    })
}

/// Stages 3 to 7, each over what the one before hands it: the columns,
/// the route through them, E along it, the program, its verification.
fn run_stages(
    setup: &Setup,
    prover: &Prover,
    clock: &mut StageClock,
) -> Result<(Program, verify::Verified), PlanError> {
    let columns = clock.run(StageName::Columns, prover, || {
        columns::Columns::build(setup, prover)
    })?;
    let route = clock.run(StageName::Graph, prover, || graph::route(columns, prover))?;
    let extruded = clock.run(StageName::Extrusion, prover, || {
        extrusion::extrude(setup, &route.sections)
    });
    let (program, program_warning) = clock.run(StageName::Program, prover, || {
        program::assemble(setup, &route, &extruded.e, prover)
    })?;
    let mut verified = clock.run(StageName::Verify, prover, || {
        verify::verify(setup, &route, &extruded, &program, prover)
    })?;
    verified.warnings.splice(0..0, program_warning);
    Ok((program, verified))
}

/// The stages' records as they end (wall time, and the collision queries
/// a prover answered meanwhile), each told to the caller.
struct StageClock<'t> {
    tell: &'t (dyn Fn(Progress) + Sync),
    stages: Vec<Stage>,
    since: Instant,
    asked: u64,
    answering: Answering,
}

impl<'t> StageClock<'t> {
    fn new(tell: &'t (dyn Fn(Progress) + Sync)) -> Self {
        StageClock {
            tell,
            stages: Vec::new(),
            since: Instant::now(),
            asked: 0,
            answering: Answering::default(),
        }
    }

    /// Run stage `name` (`stage`), told as it begins and recorded as it
    /// ends, with the queries `prover` answered since the last stage ended;
    /// the memory the stage freed goes back to the system first.
    fn run<T>(&mut self, name: StageName, prover: &Prover, stage: impl FnOnce() -> T) -> T {
        (self.tell)(Progress::Stage(name));
        let out = stage();
        release_freed_memory();
        let asked = prover.queries();
        let answering = prover.answering();
        self.record(Stage {
            name: name.as_str().into(),
            seconds: self.since.elapsed().as_secs_f64(),
            queries: asked - self.asked,
            answering: answering - self.answering,
        });
        self.asked = asked;
        self.answering = answering;
        self.since = Instant::now();
        out
    }

    /// Tell and keep the record of a stage that ran elsewhere.
    fn record(&mut self, stage: Stage) {
        (self.tell)(Progress::Done(&stage));
        self.stages.push(stage);
    }
}

#[cfg(test)]
mod tests {
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

    /// Every stage begins and ends under the one name it has, in the order
    /// [`StageName::ALL`] lists them (the prepared stages, which ran
    /// before the plan began, only end).
    #[test]
    fn stages_begin_and_end_under_one_name() {
        let mut begun = Vec::new();
        let mut ended = Vec::new();
        let p = default_plan(&mut |e| match e {
            Progress::Stage(name) => begun.push(name.as_str().to_string()),
            Progress::Done(s) => ended.push(s.name.clone()),
            Progress::Queries { .. } => {}
        });
        let all: Vec<&str> = StageName::ALL.iter().map(|s| s.as_str()).collect();
        assert_eq!(ended, all);
        assert_eq!(begun, all[2..7]);
        let kept: Vec<&str> = p.stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(kept, all);
    }

    /// The embedded default job planned with the default settings on the
    /// cpu backend, `progress` hearing it.
    fn default_plan(progress: &mut (dyn FnMut(Progress) + Send)) -> Plan {
        let job = crate::default_job::job();
        let scene = crate::default_job::scene();
        let m = Machine::default();
        let backend = crate::collide::cpu::CpuBackend::new(&scene);
        let opts = PlanOptions::default();
        plan(&scene, &job.toolpath, &m, &backend, &opts, progress).unwrap()
    }

    /// Each stage records the backend calls made while it ran and the
    /// time they took, within its own wall time; the stages that ask
    /// nothing record none.
    #[test]
    fn stages_record_the_backend_calls_they_made() {
        let p = default_plan(&mut |_| {});
        for s in &p.stages {
            let a = s.answering;
            assert_eq!(a.calls > 0, s.queries > 0, "{}: {a:?}", s.name);
            assert!(
                a.seconds <= s.seconds,
                "{}: {a:?} in {} s",
                s.name,
                s.seconds
            );
            assert_eq!(a.beside, 0, "the cpu backend sends nothing beside");
        }
        let columns = p.stages.iter().find(|s| s.name == "columns").unwrap();
        assert!(columns.answering.seconds > 0.0);
    }
}
