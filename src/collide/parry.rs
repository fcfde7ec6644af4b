//! The `parry` backend: the same semantics from parry3d's own BVH and
//! intersection primitives, as fast as parry honestly allows. It is the
//! baseline every speed claim is measured against.
//!
//! - Whole groups (the platform, a layer printed entirely before the
//!   cutoff): one `intersection_test` of the head `TriMesh` against the
//!   group's `TriMesh`, so parry's own BVH does the culling. If nothing
//!   crosses, each connected component of the group lies wholly inside or
//!   outside the head, so one `contains_point` per component decides
//!   containment.
//! - The layer the cutoff cuts is also kept as chunks of consecutive stamps
//!   (each its own `TriMesh`): chunks printed entirely before the cutoff
//!   get the whole-group test; in the one chunk the cutoff cuts, the
//!   chunk's BVH yields the triangles under the head's box and each existing
//!   one is tested with `intersection_test` (triangle vs head mesh) and,
//!   failing that, one vertex with `contains_point`.
//! - The safety margin is parry's answer too: with a positive margin the
//!   crossing test becomes `closest_points` with `max_dist = margin`
//!   (`Intersecting` or `WithinMargin` collide; GJK on the triangle pairs
//!   its BVH cannot rule out), on the same whole groups and chunk
//!   triangles, and the boxes used for culling are grown by the margin.
//!   Containment is unchanged.
//! - A margin with a slope (it grows with distance from the tip): a group
//!   is first tested at the largest margin any of its triangles can need
//!   (its box's farthest corner from the tip); only if something lies
//!   that near are its triangles tested one by one, each at its own.
//!
//! Rayon parallelises over the batch.

use super::{check_finite, Backend, CollideError, Query};
use crate::geometry::Mesh;
use crate::scene::Scene;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::{Matrix, Pose, Rotation, Vector};
use parry3d::query::{closest_points, intersection_test, ClosestPoints, PointQuery};
use parry3d::shape::Shape;
use parry3d::shape::{TriMesh, TriMeshFlags};
use rayon::prelude::*;

struct Group {
    /// The layer's trailing pieces of consecutive stamps, used instead of
    /// the whole mesh when the cutoff falls inside this group.
    chunks: Vec<Group>,
    mesh: TriMesh,
    stamps: Vec<u32>,
    min_stamp: u32,
    max_stamp: u32,
    aabb: Aabb,
    /// One vertex per connected component.
    representatives: Vec<Vector>,
}

/// One query as the group tests see it.
struct Near {
    /// The head's pose in the part frame.
    pose: Pose,
    /// The head's box (part frame).
    head_aabb: Aabb,
    /// The tip (part frame).
    tip: Vector,
    cutoff: u32,
    margin: f32,
    slope: f32,
}

impl Near {
    /// The largest margin anything inside `aabb` can need.
    fn margin_within(&self, aabb: &Aabb) -> f32 {
        if self.slope > 0.0 {
            let far = (aabb.mins - self.tip)
                .abs()
                .max((aabb.maxs - self.tip).abs());
            self.margin + self.slope * far.length()
        } else {
            self.margin
        }
    }

    /// The margin the triangle (part frame) must keep: grown by the slope
    /// at its corner farthest from the tip.
    fn margin_of(&self, tri: &parry3d::shape::Triangle) -> f32 {
        if self.slope > 0.0 {
            let far = [tri.a, tri.b, tri.c]
                .map(|v| (v - self.tip).length())
                .into_iter()
                .fold(0.0f32, f32::max);
            self.margin + self.slope * far
        } else {
            self.margin
        }
    }
}

/// The `parry` backend.
pub struct ParryBackend {
    head: TriMesh,
    groups: Vec<Group>,
}

fn vector(v: [f32; 3]) -> Vector {
    Vector::new(v[0], v[1], v[2])
}

fn trimesh(m: &Mesh, flags: TriMeshFlags) -> Result<TriMesh, CollideError> {
    TriMesh::with_flags(
        m.vertices.iter().map(|v| vector(*v)).collect(),
        m.triangles.clone(),
        flags,
    )
    .map_err(|e| CollideError::Unavailable(format!("parry rejected a mesh: {e}")))
}

/// One vertex per connected component (union-find over shared vertices).
fn component_representatives(m: &Mesh) -> Vec<Vector> {
    let mut parent: Vec<u32> = (0..m.vertices.len() as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for t in &m.triangles {
        let a = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = find(&mut parent, v);
            parent[b as usize] = a;
        }
    }
    let mut seen = vec![false; m.vertices.len()];
    let mut reps = Vec::new();
    for t in &m.triangles {
        let r = find(&mut parent, t[0]);
        if !seen[r as usize] {
            seen[r as usize] = true;
            reps.push(vector(m.vertices[t[0] as usize]));
        }
    }
    reps
}

/// Triangles per chunk of a layer the cutoff cuts.
const CHUNK: usize = 512;

fn group(m: &Mesh, stamps: Vec<u32>, chunks: Vec<Group>) -> Result<Group, CollideError> {
    let mesh = trimesh(m, TriMeshFlags::empty())?;
    let min_stamp = stamps.iter().copied().min().unwrap_or(u32::MAX);
    let max_stamp = stamps.iter().copied().max().unwrap_or(0);
    Ok(Group {
        aabb: mesh.local_aabb(),
        representatives: component_representatives(m),
        chunks,
        mesh,
        stamps,
        min_stamp,
        max_stamp,
    })
}

impl ParryBackend {
    /// Build parry's structures for `scene`.
    pub fn new(scene: &Scene) -> Result<Self, CollideError> {
        // ORIENTED gives pseudo-normals, which `contains_point` needs.
        let head = trimesh(&scene.head.mesh, TriMeshFlags::ORIENTED)?;
        let groups = scene
            .groups
            .par_iter()
            .map(|g| {
                let mut chunks = Vec::new();
                if g.layer.is_some() && g.stamps.len() > CHUNK {
                    let mut order: Vec<usize> = (0..g.stamps.len()).collect();
                    order.sort_by_key(|&i| (g.stamps[i], i));
                    for part in order.chunks(CHUNK) {
                        let sub = Mesh {
                            vertices: g.mesh.vertices.clone(),
                            triangles: part.iter().map(|&i| g.mesh.triangles[i]).collect(),
                        };
                        let stamps = part.iter().map(|&i| g.stamps[i]).collect();
                        chunks.push(group(&sub, stamps, Vec::new())?);
                    }
                }
                group(&g.mesh, g.stamps.clone(), chunks)
            })
            .collect::<Result<Vec<_>, CollideError>>()?;
        Ok(ParryBackend { head, groups })
    }

    fn hits(&self, q: &Query) -> bool {
        let c = &q.pose.cols;
        let rot = Rotation::from_mat3(&Matrix::from_cols(vector(c[0]), vector(c[1]), vector(c[2])));
        let pose = Pose::from_parts(vector(q.pose.tip), rot);
        let head_aabb = self.head.aabb(&pose);
        let near = Near {
            pose,
            head_aabb,
            tip: vector(q.pose.tip),
            cutoff: q.cutoff,
            margin: q.margin,
            slope: q.slope,
        };
        self.groups.iter().any(|g| self.group_hits(g, &near))
    }

    /// Does `shape` (part frame) cross the head, or, with a positive
    /// `margin`, come within it? Parry's own answer: the margin goes to
    /// its `closest_points` as `max_dist`.
    fn crosses_or_near(&self, near: &Near, shape: &dyn Shape, margin: f32) -> bool {
        let identity = Pose::identity();
        if margin > 0.0 {
            closest_points(&near.pose, &self.head, &identity, shape, margin)
                .map(|r| !matches!(r, ClosestPoints::Disjoint))
                .unwrap_or(true)
        } else {
            intersection_test(&near.pose, &self.head, &identity, shape)
                .map(|r| r.intersecting)
                .unwrap_or(true)
        }
    }

    fn contains(&self, near: &Near, p: Vector) -> bool {
        near.head_aabb.contains_local_point(p) && self.head.contains_point(&near.pose, p)
    }

    fn group_hits(&self, g: &Group, near: &Near) -> bool {
        // Everything within its margin of the head lies in the head's box
        // grown by the largest margin the group can need.
        let margin = near.margin_within(&g.aabb);
        let reach = near.head_aabb.loosened(margin);
        if g.min_stamp >= near.cutoff || !g.aabb.intersects(&reach) {
            return false;
        }
        if g.max_stamp < near.cutoff {
            if !self.crosses_or_near(near, &g.mesh, margin) {
                return g.representatives.iter().any(|r| self.contains(near, *r));
            }
            if near.slope == 0.0 {
                return true;
            }
            // Something lies within the largest margin: each triangle
            // against its own (containment with it).
        } else if !g.chunks.is_empty() {
            return g.chunks.iter().any(|c| self.group_hits(c, near));
        }
        let hit = g.mesh.bvh().intersect_aabb(&reach).any(|id| {
            if g.stamps[id as usize] >= near.cutoff {
                return false;
            }
            let tri = g.mesh.triangle(id);
            self.crosses_or_near(near, &tri, near.margin_of(&tri)) || self.contains(near, tri.a)
        });
        hit
    }
}

impl Backend for ParryBackend {
    fn name(&self) -> &'static str {
        "parry"
    }

    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        check_finite(queries)?;
        Ok(queries.par_iter().map(|q| self.hits(q)).collect())
    }
}
