//! The checks a mesh passes before any generator touches it: finite
//! coordinates, no zero-area triangles, every edge shared by at most two
//! consistently wound triangles (manifold), and — for solids — closed and
//! outward-facing. Each failure is one [`GenerateError`] naming the problem
//! and the fix.

use super::GenerateError;
use crate::geometry::{cross, length, sub, Mesh};
use std::collections::HashMap;

/// Weld bit-identical vertices and check that the result is a manifold
/// surface (open edges allowed) without degenerate triangles.
pub fn surface(mesh: &Mesh) -> Result<Mesh, GenerateError> {
    if mesh.triangles.is_empty() {
        return Err(GenerateError::Empty("the mesh has no triangles".into()));
    }
    if mesh.vertices.iter().flatten().any(|c| !c.is_finite()) {
        return Err(GenerateError::Empty(
            "the mesh has non-finite coordinates: re-export it".into(),
        ));
    }
    let m = mesh.welded();
    let degenerate: Vec<usize> = (0..m.triangles.len())
        .filter(|&i| {
            let t = m.triangles[i];
            let [a, b, c] = m.corners(i);
            t[0] == t[1]
                || t[1] == t[2]
                || t[0] == t[2]
                || length(cross(sub(b, a), sub(c, a))) <= 0.0
        })
        .collect();
    if let Some(&first) = degenerate.first() {
        return Err(GenerateError::Degenerate {
            count: degenerate.len(),
            first,
        });
    }
    let stats = edge_stats(&m);
    if stats.non_manifold > 0 {
        let (a, b) = stats.first_non_manifold;
        return Err(GenerateError::NonManifold {
            count: stats.non_manifold,
            a,
            b,
        });
    }
    if stats.same_direction > 0 {
        return Err(GenerateError::Inconsistent {
            count: stats.same_direction,
        });
    }
    Ok(m)
}

/// [`surface`], and closed and outward-facing (positive volume).
pub fn solid(mesh: &Mesh) -> Result<Mesh, GenerateError> {
    let m = surface(mesh)?;
    let open = edge_stats(&m).boundary;
    if open > 0 {
        return Err(GenerateError::Open { count: open });
    }
    let volume = m.signed_volume();
    if volume.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(GenerateError::InsideOut { volume });
    }
    Ok(m)
}

/// Edge counts by kind.
struct EdgeStats {
    /// Undirected edges with one triangle.
    boundary: usize,
    /// Undirected edges with more than two triangles.
    non_manifold: usize,
    /// The first of those (smallest vertex pair).
    first_non_manifold: (u32, u32),
    /// Undirected edges with two triangles winding the same way.
    same_direction: usize,
}

fn edge_stats(m: &Mesh) -> EdgeStats {
    // (min, max) → (uses in min→max direction, uses in max→min direction)
    let mut uses: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = uses.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    let mut s = EdgeStats {
        boundary: 0,
        non_manifold: 0,
        first_non_manifold: (u32::MAX, u32::MAX),
        same_direction: 0,
    };
    for (&key, &(f, r)) in &uses {
        match f + r {
            1 => s.boundary += 1,
            2 if f != 1 => s.same_direction += 1,
            2 => {}
            _ => {
                s.non_manifold += 1;
                s.first_non_manifold = s.first_non_manifold.min(key);
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::box_mesh;

    #[test]
    fn a_box_is_a_solid() {
        let m = solid(&box_mesh([0.0; 3], [1.0, 2.0, 3.0])).unwrap();
        assert!((m.signed_volume() - 6.0).abs() < 1e-9);
    }

    #[test]
    fn open_degenerate_non_manifold_and_flipped_meshes_are_refused() {
        let b = box_mesh([0.0; 3], [1.0; 3]);
        let mut open = b.clone();
        open.triangles.pop();
        assert!(matches!(
            solid(&open),
            Err(GenerateError::Open { count: 3 })
        ));
        assert!(surface(&open).is_ok());

        let mut deg = b.clone();
        deg.vertices.push([0.5, 0.5, 0.5]);
        deg.vertices.push([0.6, 0.6, 0.6]);
        deg.vertices.push([0.7, 0.7, 0.7]);
        deg.triangles.push([8, 9, 10]);
        let e = solid(&deg).unwrap_err();
        assert!(
            matches!(
                e,
                GenerateError::Degenerate {
                    count: 1,
                    first: 12
                }
            ),
            "{e}"
        );

        // A fin: a third triangle on one of the box's edges.
        let mut fin = b.clone();
        let t0 = fin.triangles[0];
        fin.vertices.push([5.0, 5.0, 5.0]);
        fin.triangles.push([t0[0], t0[1], 8]);
        let e = surface(&fin).unwrap_err();
        assert!(
            matches!(e, GenerateError::NonManifold { count: 1, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("non-manifold"));

        let flipped = Mesh {
            vertices: b.vertices.clone(),
            triangles: b.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect(),
        };
        assert!(matches!(
            solid(&flipped),
            Err(GenerateError::InsideOut { .. })
        ));

        let mut mixed = b.clone();
        let t = mixed.triangles[0];
        mixed.triangles[0] = [t[0], t[2], t[1]];
        assert!(matches!(
            surface(&mixed),
            Err(GenerateError::Inconsistent { .. })
        ));
    }
}
