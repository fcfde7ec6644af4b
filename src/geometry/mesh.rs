//! Indexed triangle meshes and the clean-ups every loaded mesh goes through:
//! welding equal vertices, dropping zero-area triangles, checking that a
//! mesh is closed, and splitting long triangles.

use super::{cross, length, sub, V3};
use rustc_hash::FxHashMap as HashMap;

/// An indexed triangle mesh (mm).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub vertices: Vec<V3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The three corners of triangle `i`.
    pub fn corners(&self, i: usize) -> [V3; 3] {
        let t = self.triangles[i];
        [
            self.vertices[t[0] as usize],
            self.vertices[t[1] as usize],
            self.vertices[t[2] as usize],
        ]
    }

    /// Merge bit-identical vertices so shared edges share indices.
    pub fn welded(&self) -> Mesh {
        let mut map: HashMap<[u32; 3], u32> = HashMap::default();
        let mut vertices = Vec::new();
        let remap: Vec<u32> = self
            .vertices
            .iter()
            .map(|v| {
                let key = [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()];
                *map.entry(key).or_insert_with(|| {
                    vertices.push(*v);
                    (vertices.len() - 1) as u32
                })
            })
            .collect();
        let triangles = self
            .triangles
            .iter()
            .map(|t| {
                [
                    remap[t[0] as usize],
                    remap[t[1] as usize],
                    remap[t[2] as usize],
                ]
            })
            .collect();
        Mesh {
            vertices,
            triangles,
        }
    }

    /// Drop triangles of zero area (repeated index or collinear corners);
    /// returns the mesh and how many were dropped.
    pub fn without_degenerate(&self) -> (Mesh, usize) {
        let keep: Vec<[u32; 3]> = self
            .triangles
            .iter()
            .copied()
            .filter(|t| {
                let [a, b, c] = [
                    self.vertices[t[0] as usize],
                    self.vertices[t[1] as usize],
                    self.vertices[t[2] as usize],
                ];
                length(cross(sub(b, a), sub(c, a))) > 0.0
            })
            .collect();
        let dropped = self.triangles.len() - keep.len();
        (
            Mesh {
                vertices: self.vertices.clone(),
                triangles: keep,
            },
            dropped,
        )
    }

    /// Number of directed edges without exactly one opposite partner: 0 for a
    /// closed, consistently oriented (watertight) mesh.
    pub fn open_edges(&self) -> usize {
        let mut count: HashMap<(u32, u32), i32> = HashMap::default();
        for t in &self.triangles {
            for k in 0..3 {
                *count.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        count
            .iter()
            .filter(|(&(a, b), &c)| c != 1 || count.get(&(b, a)).copied() != Some(1))
            .count()
    }

    /// Total area of the triangles (f64).
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let p = |i: u32| self.vertices[i as usize].map(f64::from);
                let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
            })
            .sum()
    }

    /// Signed volume (positive when oriented outwards).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let p = |i: u32| {
                    let v = self.vertices[i as usize];
                    [v[0] as f64, v[1] as f64, v[2] as f64]
                };
                let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    /// Split every triangle whose longest edge exceeds `max_edge` by
    /// longest-edge bisection, sharing midpoints between neighbours. The
    /// surface is unchanged; smaller triangles just cull better.
    pub fn subdivided(&self, max_edge: f32) -> Mesh {
        let mut vertices = self.vertices.clone();
        let mut mids: HashMap<(u32, u32), u32> = HashMap::default();
        let mut out = Vec::with_capacity(self.triangles.len());
        let mut stack: Vec<[u32; 3]> = self.triangles.iter().rev().copied().collect();
        while let Some(t) = stack.pop() {
            let p = |i: u32| vertices[i as usize];
            let lens = [
                length(sub(p(t[1]), p(t[0]))),
                length(sub(p(t[2]), p(t[1]))),
                length(sub(p(t[0]), p(t[2]))),
            ];
            let k = (0..3)
                .max_by(|&a, &b| lens[a].total_cmp(&lens[b]))
                .unwrap_or(0);
            if lens[k] <= max_edge {
                out.push(t);
                continue;
            }
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let key = (a.min(b), a.max(b));
            let m = *mids.entry(key).or_insert_with(|| {
                let (pa, pb) = (vertices[a as usize], vertices[b as usize]);
                vertices.push([
                    (pa[0] + pb[0]) * 0.5,
                    (pa[1] + pb[1]) * 0.5,
                    (pa[2] + pb[2]) * 0.5,
                ]);
                (vertices.len() - 1) as u32
            });
            stack.push([m, b, c]);
            stack.push([a, m, c]);
        }
        Mesh {
            vertices,
            triangles: out,
        }
    }

    /// Apply `f` to every vertex.
    pub fn map_vertices(&self, f: impl Fn(V3) -> V3) -> Mesh {
        Mesh {
            vertices: self.vertices.iter().map(|v| f(*v)).collect(),
            triangles: self.triangles.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        }
    }

    #[test]
    fn closed_and_volume() {
        let m = tetra();
        assert_eq!(m.open_edges(), 0);
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-9);
        let mut open = m.clone();
        open.triangles.pop();
        assert_eq!(open.open_edges(), 3);
    }

    #[test]
    fn subdivision_keeps_area_and_bounds_edges() {
        let m = tetra();
        let s = m.subdivided(0.2);
        assert!((m.area() - s.area()).abs() < 1e-4);
        for i in 0..s.triangles.len() {
            let [a, b, c] = s.corners(i);
            for (p, q) in [(a, b), (b, c), (c, a)] {
                assert!(length(sub(p, q)) <= 0.2 + 1e-6);
            }
        }
    }
}
