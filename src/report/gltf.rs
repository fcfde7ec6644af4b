//! A glTF 2.0 binary (`.glb`) document built in memory: one binary buffer,
//! its views and accessors (every one carrying its exact min/max where the
//! format asks for it), meshes, materials, a node tree and animations.
//! Written by hand: the format is a JSON document and one buffer, and the
//! scenes maamplan writes need nothing a crate would add.

use serde_json::{json, Value};

/// `bufferView.target` of vertex attributes.
const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` of indices.
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The document being built.
#[derive(Default)]
pub struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    roots: Vec<usize>,
    channels: Vec<Value>,
    samplers: Vec<Value>,
}

/// How an animation sampler interpolates between its keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Straight between keys (rotations: spherical).
    Linear,
    /// Each key's value holds until the next.
    Step,
}

impl Builder {
    /// A buffer view over `bytes` (4-byte aligned), for `target` if any.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    /// An accessor of `count` floats shaped `kind` over a new view.
    fn floats(&mut self, data: &[f32], kind: &str, width: usize, target: Option<u32>) -> usize {
        let view = self.view(bytemuck::cast_slice(data), target);
        let mut lo = vec![f32::INFINITY; width];
        let mut hi = vec![f32::NEG_INFINITY; width];
        for v in data.chunks_exact(width) {
            for k in 0..width {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        self.accessors.push(json!({"bufferView": view, "componentType": 5126, "count": data.len() / width, "type": kind, "min": lo, "max": hi}));
        self.accessors.len() - 1
    }

    /// Vertex positions (with their bounds).
    pub fn positions(&mut self, v: &[[f32; 3]]) -> usize {
        self.floats(v.as_flattened(), "VEC3", 3, Some(ARRAY_BUFFER))
    }

    /// Per-vertex RGBA colours.
    pub fn colors(&mut self, v: &[[f32; 4]]) -> usize {
        self.floats(v.as_flattened(), "VEC4", 4, Some(ARRAY_BUFFER))
    }

    /// Triangle indices.
    pub fn triangles(&mut self, t: &[[u32; 3]]) -> usize {
        self.indices(t.as_flattened())
    }

    /// Indices of any primitive (lines: pairs).
    pub fn indices(&mut self, idx: &[u32]) -> usize {
        let view = self.view(bytemuck::cast_slice(idx), Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    /// Key times of an animation sampler (seconds, increasing).
    pub fn times(&mut self, t: &[f32]) -> usize {
        self.floats(t, "SCALAR", 1, None)
    }

    /// Animation outputs: translations or scales.
    pub fn vec3_keys(&mut self, v: &[[f32; 3]]) -> usize {
        self.floats(v.as_flattened(), "VEC3", 3, None)
    }

    /// Animation outputs: rotations as quaternions `[x, y, z, w]`.
    pub fn quat_keys(&mut self, v: &[[f32; 4]]) -> usize {
        self.floats(v.as_flattened(), "VEC4", 4, None)
    }

    /// A material: its index.
    pub fn material(&mut self, name: &str, rgba: [f32; 4], unlit_look: bool) -> usize {
        let mut m = json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": rgba, "metallicFactor": 0.0, "roughnessFactor": 0.8}, "doubleSided": true});
        if rgba[3] < 1.0 {
            m["alphaMode"] = json!("BLEND");
        }
        if unlit_look {
            // Lines and markers: as bright in any light.
            m["emissiveFactor"] = json!([rgba[0], rgba[1], rgba[2]]);
        }
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// A mesh of `primitives`: its index.
    pub fn mesh(&mut self, name: &str, primitives: Vec<Value>) -> usize {
        self.meshes
            .push(json!({"name": name, "primitives": primitives}));
        self.meshes.len() - 1
    }

    /// A node (`json` holds its name, mesh, transform, extras): its index.
    /// Nodes are roots of the scene unless given to [`Builder::child`].
    pub fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.roots.push(self.nodes.len() - 1);
        self.nodes.len() - 1
    }

    /// Make `child` a child of `parent` (no longer a root).
    pub fn child(&mut self, parent: usize, child: usize) {
        self.roots.retain(|&r| r != child);
        let children = self.nodes[parent]
            .as_object_mut()
            .expect("a node is an object")
            .entry("children")
            .or_insert_with(|| json!([]));
        children
            .as_array_mut()
            .expect("children are an array")
            .push(json!(child));
    }

    /// Animate `path` (`translation`, `rotation` or `scale`) of `node`
    /// by the keys `input` (times) and `output` (values).
    pub fn channel(
        &mut self,
        node: usize,
        path: &str,
        input: usize,
        output: usize,
        how: Interpolation,
    ) {
        let interpolation = match how {
            Interpolation::Linear => "LINEAR",
            Interpolation::Step => "STEP",
        };
        self.samplers
            .push(json!({"input": input, "output": output, "interpolation": interpolation}));
        self.channels.push(
            json!({"sampler": self.samplers.len() - 1, "target": {"node": node, "path": path}}),
        );
    }

    /// The GLB file: header, the JSON chunk and the binary chunk, each
    /// padded to four bytes. `scene` names the scene, `animation` the
    /// animation (if any channel was added).
    pub fn into_glb(mut self, scene: &str, animation: &str) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": concat!("maamplan ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"name": scene, "nodes": self.roots}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        if !self.channels.is_empty() {
            doc["animations"] =
                json!([{"name": animation, "channels": self.channels, "samplers": self.samplers}]);
        }
        let mut js = serde_json::to_vec(&doc).expect("JSON");
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        let total = 12 + 8 + js.len() + 8 + self.bin.len();
        let mut head = Vec::with_capacity(total - self.bin.len());
        head.extend_from_slice(b"glTF");
        head.extend_from_slice(&2u32.to_le_bytes());
        head.extend_from_slice(&(total as u32).to_le_bytes());
        head.extend_from_slice(&(js.len() as u32).to_le_bytes());
        head.extend_from_slice(b"JSON");
        head.extend_from_slice(&js);
        head.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        head.extend_from_slice(b"BIN\0");
        // The buffer is most of the file: the header goes in front of it
        // rather than the buffer being copied after the header.
        self.bin.splice(0..0, head);
        self.bin
    }
}

/// Quaternion `[x, y, z, w]` of a rotation given by its columns.
pub fn quaternion(c: [[f32; 3]; 3]) -> [f32; 4] {
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

    #[test]
    fn children_leave_the_roots() {
        let mut b = Builder::default();
        let a = b.node(json!({"name": "a"}));
        let c = b.node(json!({"name": "c"}));
        b.child(a, c);
        assert_eq!(b.roots, vec![a]);
        assert_eq!(b.nodes[a]["children"], json!([c]));
    }
}
