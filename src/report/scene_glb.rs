//! The plan as a 3D scene, `scene.glb` (glTF 2.0, binary): the platform
//! and the printed part (layer surfaces), the toolpath as lines coloured by
//! status, and the head at the worst input poses (red) and at their planned
//! replacements (green). Still: `program.glb` (`program_glb.rs`) is the
//! program running.

use super::gltf::{quaternion, Builder};
use crate::kinematics::{head_pose, Machine};
use crate::plan::Plan;
use crate::scene::Scene;
use serde_json::json;

/// Line colours (RGBA): free, was colliding, singular, break.
pub const COLORS: [[f32; 4]; 4] = [
    [0.15, 0.65, 0.25, 1.0],
    [0.85, 0.10, 0.10, 1.0],
    [0.95, 0.60, 0.05, 1.0],
    [0.70, 0.10, 0.80, 1.0],
];

/// How many colliding input poses (and their replacements) to show.
pub const HEADS: usize = 3;

/// The GLB bytes for `plan` over `scene`.
pub fn scene_glb(scene: &Scene, plan: &Plan, machine: &Machine) -> Vec<u8> {
    let mut b = Builder::default();
    // Materials by index: platform, part, toolpath, head at an input
    // pose, head at a planned pose.
    b.material("platform", [0.55, 0.55, 0.6, 1.0], false);
    b.material("part", [0.85, 0.80, 0.70, 1.0], false);
    b.material("toolpath", [1.0, 1.0, 1.0, 1.0], false);
    b.material("head at input pose", [0.9, 0.1, 0.1, 0.6], false);
    b.material("head at planned pose", [0.1, 0.7, 0.2, 0.6], false);
    part(&mut b, scene);
    toolpath(&mut b, plan);
    heads(&mut b, scene, plan, machine);
    b.into_glb("plan", "")
}

/// The platform and the layer surfaces: one mesh, node `part`.
fn part(b: &mut Builder, scene: &Scene) {
    let mut prims = Vec::new();
    for g in &scene.groups {
        if g.mesh.triangles.is_empty() {
            continue;
        }
        let pos = b.positions(&g.mesh.vertices);
        let idx = b.triangles(&g.mesh.triangles);
        let mat = if g.layer.is_none() { 0 } else { 1 };
        prims.push(json!({"attributes": {"POSITION": pos}, "indices": idx, "material": mat}));
    }
    let mesh = b.mesh("printed part", prims);
    b.node(json!({"name": "part", "mesh": mesh}));
}

/// The toolpath: one line per segment, coloured by its end's status.
fn toolpath(b: &mut Builder, plan: &Plan) {
    let w = &plan.waypoints;
    let mut lp = Vec::new();
    let mut lc = Vec::new();
    for i in 1..w.len() {
        if w[i].section_start || w[i].layer != w[i - 1].layer {
            continue;
        }
        let s = if w[i].break_before {
            3
        } else if w[i].was_colliding {
            1
        } else if w[i].singular {
            2
        } else {
            0
        };
        for v in [&w[i - 1], &w[i]] {
            lp.push(v.p.map(|x| x as f32));
            lc.push(COLORS[s]);
        }
    }
    if lp.is_empty() {
        return;
    }
    let pos = b.positions(&lp);
    let col = b.colors(&lc);
    let mesh = b.mesh(
        "toolpath",
        vec![json!({"attributes": {"POSITION": pos, "COLOR_0": col}, "mode": 1, "material": 2})],
    );
    b.node(json!({"name": "toolpath", "mesh": mesh}));
}

/// The head at the first few colliding input poses and at their plans.
fn heads(b: &mut Builder, scene: &Scene, plan: &Plan, machine: &Machine) {
    let w = &plan.waypoints;
    let worst: Vec<usize> = (0..w.len())
        .filter(|&i| w[i].was_colliding)
        .take(HEADS)
        .collect();
    if worst.is_empty() {
        return;
    }
    let pos = b.positions(&scene.head.mesh.vertices);
    let idx = b.triangles(&scene.head.mesh.triangles);
    let input = b.mesh(
        "head (input)",
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx, "material": 3})],
    );
    let planned = b.mesh(
        "head (plan)",
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx, "material": 4})],
    );
    for &i in &worst {
        for (mesh, axes) in [(input, &plan.input_axes[i]), (planned, &w[i].axes)] {
            let pose = head_pose(machine.rotary, w[i].p, axes.tilt, axes.c);
            let label = if mesh == input { "input" } else { "plan" };
            b.node(json!({
                "name": format!("head at waypoint {i} ({label})"),
                "mesh": mesh,
                "rotation": quaternion(pose.cols),
                "translation": pose.tip,
            }));
        }
    }
}
