//! The JSON documents the commands write beside their outputs: `plan`'s
//! report.json, `simulate`'s report.json and `check --json`.
//!
//! Each is built as a [`serde_json::Value`], whose objects keep their keys
//! sorted, so every level of a document (the machine and the metrics
//! included) lists its keys in the same order whichever way it was put
//! together.

use crate::check::{LayerCount, Verdicts};
use crate::kinematics::Machine;
use crate::plan::{Plan, Skip};
use crate::scene::PartSource;
use crate::simulate::Simulation;
use crate::toolpath::Toolpath;
use serde::Serialize;
use serde_json::{json, Value};

/// A waypoint the plan does not visit, as report.json lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SkippedWaypoint {
    /// Global waypoint index.
    pub index: usize,
    /// Layer index.
    pub layer: usize,
    /// The layer's name (its file stem).
    pub layer_name: String,
    /// Why it is not visited.
    pub reason: Skip,
}

/// The waypoints `plan` skips, in order, with the names of their layers
/// in `toolpath` (the toolpath planned).
pub fn skipped_waypoints(plan: &Plan, toolpath: &Toolpath) -> Vec<SkippedWaypoint> {
    plan.waypoints
        .iter()
        .enumerate()
        .filter_map(|(index, w)| {
            w.skipped.map(|reason| SkippedWaypoint {
                index,
                layer: w.layer,
                layer_name: toolpath.layers[w.layer].name.clone(),
                reason,
            })
        })
        .collect()
}

/// What a plan's report.json records besides the plan: where the inputs
/// came from and how the run went.
pub struct PlanRun<'a> {
    /// The toolpath as the user named it.
    pub source: &'a str,
    /// What the part printed so far was modelled from.
    pub part: PartSource,
    /// The collision backend's name.
    pub backend: &'a str,
    /// Names of the layers whose nozzle directions were reversed on loading.
    pub flipped_layers: &'a [String],
    /// Seconds per stage, the run's own (load, write, report) and the
    /// planner's ([`Plan::stages`]).
    pub stages: &'a [(String, f64)],
    /// Seconds of the whole run.
    pub seconds: f64,
    /// The command line.
    pub command: &'a str,
}

/// `plan`'s report.json: the run, the machine, the part model, the
/// input's and the plan's metrics, the skipped waypoints and the warnings
/// (the part model's first, [`super::warnings`]).
pub fn plan_report(
    machine: &Machine,
    plan: &Plan,
    skipped: &[SkippedWaypoint],
    run: &PlanRun,
) -> Value {
    let stages: serde_json::Map<String, Value> = run
        .stages
        .iter()
        .map(|(name, seconds)| (name.clone(), json!(seconds)))
        .collect();
    json!({
        "source": run.source,
        "part": run.part.name(),
        "backend": run.backend,
        "machine": machine,
        "margin": plan.margin,
        "flipped_layers": run.flipped_layers,
        "input": plan.input,
        "plan": plan.plan,
        "skipped": skipped,
        "warnings": super::warnings(run.part, &plan.warnings),
        "collision_queries": plan.queries,
        "seconds": run.seconds,
        "stages": stages,
        "command": run.command,
    })
}

/// What a simulation's report.json records besides the simulation.
pub struct SimulationRun<'a> {
    /// The program as the user named it.
    pub gcode: &'a str,
    /// The toolpath it was simulated against (or "platform only").
    pub toolpath: &'a str,
    /// What the part printed so far was modelled from.
    pub part: PartSource,
    /// Names of the toolpath's layers, by index.
    pub layer_names: &'a [String],
    /// The collision backend's name.
    pub backend: &'a str,
    /// Seconds of the whole run.
    pub seconds: f64,
    /// The command line.
    pub command: &'a str,
}

/// `simulate`'s report.json: the run, the machine, the part model and its
/// warnings, the summary and every problem at its line, with the name of
/// the layer it reads as.
pub fn simulation_report(machine: &Machine, sim: &Simulation, run: &SimulationRun) -> Value {
    let layer_name = |l: usize| run.layer_names.get(l).cloned().unwrap_or_default();
    json!({
        "gcode": run.gcode,
        "toolpath": run.toolpath,
        "part": run.part.name(),
        "warnings": super::warnings(run.part, &[]),
        "backend": run.backend,
        "machine": machine,
        "summary": sim.summary,
        "problems": sim.problems.iter().zip(sim.problem_times()).map(|(p, time)| json!({
            "line": p.line,
            "kind": p.kind,
            "value": p.value,
            "layer": p.layer.map(layer_name),
            "time_s": time,
        })).collect::<Vec<_>>(),
        "seconds": run.seconds,
        "command": run.command,
    })
}

/// What `check --json` records besides the verdicts.
pub struct CheckRun<'a> {
    /// The toolpath as the user named it.
    pub source: &'a str,
    /// What the part printed so far was modelled from.
    pub part: PartSource,
    /// The collision backend's name.
    pub backend: &'a str,
    /// The safety margin checked at (mm).
    pub margin: f64,
    /// Seconds the checks took.
    pub seconds: f64,
    /// Names of the layers whose nozzle directions were reversed on loading.
    pub flipped_layers: &'a [String],
}

/// `check --json`: the part model and its warnings, the totals, each layer's counts (`layers` pairs a
/// layer's name with them) and the colliding waypoints and moves.
pub fn check_report(run: &CheckRun, layers: &[(&str, LayerCount)], verdicts: &Verdicts) -> Value {
    let total = LayerCount::total(layers.iter().map(|l| &l.1));
    json!({
        "source": run.source,
        "part": run.part.name(),
        "warnings": super::warnings(run.part, &[]),
        "waypoints": verdicts.poses.len(),
        "colliding": total.colliding,
        "moves": verdicts.moves_checked(),
        "colliding_moves": total.colliding_moves,
        "margin": run.margin,
        "backend": run.backend,
        "seconds": run.seconds,
        "flipped_layers": run.flipped_layers,
        "layers": layers.iter().enumerate().map(|(i, (name, count))| json!({
            "index": i,
            "name": name,
            "waypoints": count.waypoints,
            "colliding": count.colliding,
            "colliding_moves": count.colliding_moves,
        })).collect::<Vec<_>>(),
        "colliding_waypoints": verdicts.colliding_waypoints(),
        "colliding_moves_into": verdicts.colliding_moves_into(),
    })
}

/// `value` as the commands write JSON: pretty, with a final newline.
pub fn pretty_bytes(value: &Value) -> Vec<u8> {
    let mut text = serde_json::to_string_pretty(value).expect("a Value always serialises");
    text.push('\n');
    text.into_bytes()
}
