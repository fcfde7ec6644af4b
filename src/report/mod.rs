//! What a process engineer looks at: plots (`plots.rs`), a 3D scene
//! (`scene_glb.rs`) and a self-contained HTML report (`html.rs`), all made
//! from a [`Plan`] (or a [`crate::simulate::Simulation`]) with no extra
//! tool; and what a program reads: the commands' JSON documents
//! (`json.rs`) and a simulation's table of moves (`moves_csv.rs`); a
//! plan's files rendered and written as one set (`plan_files.rs`).

pub mod gltf;
pub mod html;
pub mod json;
pub mod machine_bodies;
pub mod moves_csv;
pub mod plan_files;
pub mod playback;
pub mod plots;
pub mod program_glb;
pub mod render;
pub mod scene_glb;
pub mod snapshot;
pub mod watch;

use crate::kinematics::Machine;
use crate::plan::cost::CostModel;
use crate::plan::metrics::{tip_speed, Metrics};
use crate::plan::Plan;
use crate::scene::PartSource;

/// A run's warnings as its reports list them: the part model's (only the
/// platform was checked), then `others` (the planner's).
pub fn warnings(part: PartSource, others: &[String]) -> Vec<String> {
    part.warning()
        .map(str::to_string)
        .into_iter()
        .chain(others.iter().cloned())
        .collect()
}

/// The line the terminal summaries give the part model.
pub fn part_line(part: PartSource) -> String {
    format!("part model: {}", part.name())
}

/// Per-segment tip speeds (mm/s) of the input and of the plan, over the
/// segments the plan prints (same section, not a break, neither end
/// skipped, non-zero length), each with its extruder's feed.
pub fn tip_speeds(m: &Machine, plan: &Plan) -> (Vec<f64>, Vec<f64>) {
    let w = &plan.waypoints;
    let mut input = Vec::new();
    let mut planned = Vec::new();
    for i in 1..w.len() {
        if w[i].section_start
            || w[i].break_before
            || w[i].layer != w[i - 1].layer
            || w[i].skipped.is_some()
            || w[i - 1].skipped.is_some()
        {
            continue;
        }
        let len = (w[i].p[0] - w[i - 1].p[0])
            .hypot(w[i].p[1] - w[i - 1].p[1])
            .hypot(w[i].p[2] - w[i - 1].p[2]);
        if len <= 0.0 {
            continue;
        }
        let tool = m.tool_for(w[i].support);
        let cm = CostModel::new(m, tool.feed, tool.tip_speed, 1.0);
        input.push(tip_speed(
            &cm,
            len,
            &plan.input_axes[i - 1],
            &plan.input_axes[i],
        ));
        planned.push(tip_speed(&cm, len, &w[i - 1].axes, &w[i].axes));
    }
    (input, planned)
}

/// Per layer: (waypoints, colliding in the input, skipped in the plan).
pub fn layer_table(plan: &Plan) -> Vec<(usize, usize, usize)> {
    let layers = plan
        .waypoints
        .iter()
        .map(|w| w.layer + 1)
        .max()
        .unwrap_or(0);
    let mut t = vec![(0, 0, 0); layers];
    for w in &plan.waypoints {
        let r = &mut t[w.layer];
        r.0 += 1;
        r.1 += w.was_colliding as usize;
        r.2 += w.skipped.is_some() as usize;
    }
    t
}

/// The input-vs-plan summary as `(label, input, plan)` rows, shared by the
/// terminal table and the HTML report.
pub fn summary_rows(i: &Metrics, p: &Metrics) -> Vec<(&'static str, String, String)> {
    vec![
        (
            "waypoints",
            i.waypoints.to_string(),
            p.waypoints.to_string(),
        ),
        (
            "colliding poses",
            i.residual_collisions.to_string(),
            p.residual_collisions.to_string(),
        ),
        (
            "colliding edges",
            i.colliding_edges.to_string(),
            p.colliding_edges.to_string(),
        ),
        (
            "tip-speed violations",
            format!("{:.2} %", i.speed_violation_pct),
            format!("{:.2} %", p.speed_violation_pct),
        ),
        (
            "J = Σ |ΔB| + |ΔC|",
            format!("{:.0}°", i.j_deg),
            format!("{:.0}°", p.j_deg),
        ),
        (
            "largest step",
            format!("{:.1}°", i.max_step_deg),
            format!("{:.1}°", p.max_step_deg),
        ),
        (
            "singular waypoints",
            i.singular_waypoints.to_string(),
            p.singular_waypoints.to_string(),
        ),
        ("breaks", i.breaks.to_string(), p.breaks.to_string()),
        (
            "skipped waypoints",
            i.skipped_waypoints.to_string(),
            p.skipped_waypoints.to_string(),
        ),
        (
            "tip deviation while extruding",
            "—".into(),
            format!("{:.3} mm", p.tip_deviation_max_mm),
        ),
        (
            "largest C turn between extrusions",
            "—".into(),
            format!("{:.1}°", p.travel_c_max_deg),
        ),
        (
            "segments at the layer-height clamp",
            "—".into(),
            format!("{:.2} %", p.height_clamped_pct),
        ),
        (
            "axis-limit violations",
            i.axis_limit_violations.to_string(),
            p.axis_limit_violations.to_string(),
        ),
        (
            "orientation change (mean / max)",
            "—".into(),
            format!("{:.1}° / {:.1}°", p.mean_deviation_deg, p.max_deviation_deg),
        ),
    ]
}
