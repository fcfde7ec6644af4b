//! The plan as a 3D scene, `scene.glb` (glTF 2.0, binary): the platform
//! and the printed part (layer surfaces), the toolpath as lines coloured by
//! status, and the head at the worst input poses (red) and at their planned
//! replacements (green). Written by hand: the format is a JSON document and
//! one binary buffer, and every accessor carries its exact min/max.

use crate::kinematics::{head_pose, Machine};
use crate::plan::Plan;
use crate::scene::Scene;
use serde_json::{json, Value};

/// Line colours (RGBA): free, was colliding, singular, break.
pub const COLORS: [[f32; 4]; 4] = [
    [0.15, 0.65, 0.25, 1.0],
    [0.85, 0.10, 0.10, 1.0],
    [0.95, 0.60, 0.05, 1.0],
    [0.70, 0.10, 0.80, 1.0],
];

/// How many colliding input poses (and their replacements) to show.
pub const HEADS: usize = 3;

/// The glTF document being built: the binary buffer, its views and
/// accessors, the meshes and the nodes.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
}

impl Builder {
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        self.views.len() - 1
    }

    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let view = self.view(bytemuck::cast_slice(v), 34962);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in v {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        self.accessors.push(json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3", "min": lo, "max": hi}));
        self.accessors.len() - 1
    }

    fn vec4(&mut self, v: &[[f32; 4]]) -> usize {
        let view = self.view(bytemuck::cast_slice(v), 34962);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC4"}),
        );
        self.accessors.len() - 1
    }

    fn indices(&mut self, t: &[[u32; 3]]) -> usize {
        let view = self.view(bytemuck::cast_slice(t), 34963);
        self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": t.len() * 3, "type": "SCALAR"}));
        self.accessors.len() - 1
    }
}

/// Quaternion `[x, y, z, w]` of a rotation given by its columns.
fn quaternion(c: [[f32; 3]; 3]) -> [f32; 4] {
    let m = |r: usize, k: usize| c[k][r] as f64;
    let tr = m(0, 0) + m(1, 1) + m(2, 2);
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            (m(2, 1) - m(1, 2)) / s,
            (m(0, 2) - m(2, 0)) / s,
            (m(1, 0) - m(0, 1)) / s,
            0.25 * s,
        ]
    } else if m(0, 0) > m(1, 1) && m(0, 0) > m(2, 2) {
        let s = (1.0 + m(0, 0) - m(1, 1) - m(2, 2)).sqrt() * 2.0;
        [
            0.25 * s,
            (m(0, 1) + m(1, 0)) / s,
            (m(0, 2) + m(2, 0)) / s,
            (m(2, 1) - m(1, 2)) / s,
        ]
    } else if m(1, 1) > m(2, 2) {
        let s = (1.0 + m(1, 1) - m(0, 0) - m(2, 2)).sqrt() * 2.0;
        [
            (m(0, 1) + m(1, 0)) / s,
            0.25 * s,
            (m(1, 2) + m(2, 1)) / s,
            (m(0, 2) - m(2, 0)) / s,
        ]
    } else {
        let s = (1.0 + m(2, 2) - m(0, 0) - m(1, 1)).sqrt() * 2.0;
        [
            (m(0, 2) + m(2, 0)) / s,
            (m(1, 2) + m(2, 1)) / s,
            0.25 * s,
            (m(1, 0) - m(0, 1)) / s,
        ]
    };
    let l = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.map(|x| (x / l) as f32)
}

/// The GLB bytes for `plan` over `scene`.
pub fn scene_glb(scene: &Scene, plan: &Plan, machine: &Machine) -> Vec<u8> {
    let mut b = Builder::default();
    b.part(scene);
    b.toolpath(plan);
    b.heads(scene, plan, machine);
    b.into_glb()
}

/// The scene's materials, by index: platform, part, toolpath, head at an
/// input pose, head at a planned pose.
fn materials() -> Vec<Value> {
    let material = |name: &str, rgba: [f32; 4]| json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": rgba, "metallicFactor": 0.0, "roughnessFactor": 0.8}, "doubleSided": true});
    vec![
        material("platform", [0.55, 0.55, 0.6, 1.0]),
        material("part", [0.85, 0.80, 0.70, 1.0]),
        material("toolpath", [1.0, 1.0, 1.0, 1.0]),
        material("head at input pose", [0.9, 0.1, 0.1, 0.6]),
        material("head at planned pose", [0.1, 0.7, 0.2, 0.6]),
    ]
}

impl Builder {
    /// The platform and the layer surfaces: mesh 0, node `part`.
    fn part(&mut self, scene: &Scene) {
        let mut prims = Vec::new();
        for g in &scene.groups {
            if g.mesh.triangles.is_empty() {
                continue;
            }
            let pos = self.vec3(&g.mesh.vertices);
            let idx = self.indices(&g.mesh.triangles);
            let mat = if g.layer.is_none() { 0 } else { 1 };
            prims.push(json!({"attributes": {"POSITION": pos}, "indices": idx, "material": mat}));
        }
        self.meshes
            .push(json!({"name": "printed part", "primitives": prims}));
        self.nodes.push(json!({"name": "part", "mesh": 0}));
    }

    /// The toolpath: one line per segment, coloured by its end's status.
    fn toolpath(&mut self, plan: &Plan) {
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
        let pos = self.vec3(&lp);
        let col = self.vec4(&lc);
        self.meshes.push(json!({"name": "toolpath", "primitives": [{"attributes": {"POSITION": pos, "COLOR_0": col}, "mode": 1, "material": 2}]}));
        self.nodes
            .push(json!({"name": "toolpath", "mesh": self.meshes.len() - 1}));
    }

    /// The head at the first few colliding input poses and at their plans.
    fn heads(&mut self, scene: &Scene, plan: &Plan, machine: &Machine) {
        let w = &plan.waypoints;
        let worst: Vec<usize> = (0..w.len())
            .filter(|&i| w[i].was_colliding)
            .take(HEADS)
            .collect();
        if worst.is_empty() {
            return;
        }
        let pos = self.vec3(&scene.head.mesh.vertices);
        let idx = self.indices(&scene.head.mesh.triangles);
        self.meshes.push(json!({"name": "head (input)", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx, "material": 3}]}));
        self.meshes.push(json!({"name": "head (plan)", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx, "material": 4}]}));
        let hm = self.meshes.len() - 2;
        for &i in &worst {
            for (k, axes) in [(0, &plan.input_axes[i]), (1, &w[i].axes)] {
                let pose = head_pose(machine.rotary, w[i].p, axes.tilt, axes.c);
                let label = if k == 0 { "input" } else { "plan" };
                self.nodes.push(json!({
                    "name": format!("head at waypoint {i} ({label})"),
                    "mesh": hm + k,
                    "rotation": quaternion(pose.cols),
                    "translation": pose.tip,
                }));
            }
        }
    }

    /// The GLB file: header, the JSON chunk and the binary chunk, each
    /// padded to four bytes.
    fn into_glb(mut self) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let doc = json!({
            "asset": {"version": "2.0", "generator": concat!("maamplan ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"name": "plan", "nodes": (0..self.nodes.len()).collect::<Vec<_>>()}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": materials(),
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        let mut js = serde_json::to_vec(&doc).expect("JSON");
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        let total = 12 + 8 + js.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(js.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&js);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_of_known_rotations() {
        let id = quaternion([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!((id[3] - 1.0).abs() < 1e-6);
        // 90° about z: x → y.
        let q = quaternion([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((q[2] - h).abs() < 1e-6 && (q[3] - h).abs() < 1e-6);
    }
}
