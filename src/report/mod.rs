//! What a process engineer looks at: plots (`plots.rs`), a 3D scene
//! (`scene_glb.rs`) and a self-contained HTML report (`html.rs`), all made
//! from a [`Plan`] with no extra tool.

pub mod html;
pub mod plots;
pub mod scene_glb;

use crate::kinematics::Machine;
use crate::plan::metrics::tip_speed;
use crate::plan::Plan;

/// Per-segment tip speeds (mm/s) of the input and of the plan, over the
/// segments the metrics count (same section, not a break, non-zero length).
pub fn tip_speeds(m: &Machine, plan: &Plan) -> (Vec<f64>, Vec<f64>) {
    let w = &plan.waypoints;
    let mut input = Vec::new();
    let mut planned = Vec::new();
    for i in 1..w.len() {
        if w[i].section_start || w[i].break_before || w[i].layer != w[i - 1].layer {
            continue;
        }
        let len = (w[i].p[0] - w[i - 1].p[0])
            .hypot(w[i].p[1] - w[i - 1].p[1])
            .hypot(w[i].p[2] - w[i - 1].p[2]);
        if len <= 0.0 {
            continue;
        }
        input.push(tip_speed(
            m,
            len,
            &plan.input_axes[i - 1],
            &plan.input_axes[i],
        ));
        planned.push(tip_speed(m, len, &w[i - 1].axes, &w[i].axes));
    }
    (input, planned)
}

/// Per layer: (waypoints, colliding in the input, residual in the plan).
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
        r.2 += w.residual as usize;
    }
    t
}
