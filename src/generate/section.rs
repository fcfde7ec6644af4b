//! A plane cut through a triangle mesh, as polylines.
//!
//! A vertex exactly on the plane counts as above it (simulation of
//! simplicity), so every cut edge has one end strictly below and one on or
//! above, every crossed triangle gives exactly one segment, and on a
//! manifold, consistently wound mesh the segments chain into closed loops
//! (solids) or polylines ending on the boundary (open surfaces). Segments
//! run from the edge where the signed distance rises to the edge where it
//! falls (in the triangle's winding), so neighbours chain head to tail.

use crate::geometry::Mesh;
use glam::DVec3;
use std::collections::HashMap;

/// One point of a section: on the mesh edge `edge` at `pos`, a fraction `t`
/// of the way from `edge.0` to `edge.1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionPoint {
    /// Position (mm).
    pub pos: DVec3,
    /// The cut edge's vertices.
    pub edge: (u32, u32),
    /// Fraction along the edge.
    pub t: f64,
}

/// A connected piece of a section.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyline {
    /// Points in order (a closed loop does not repeat its first point).
    pub points: Vec<SectionPoint>,
    /// Whether the last point joins the first.
    pub closed: bool,
}

/// Cut `mesh` (manifold, consistently wound) with the plane
/// `{x : normal · x = offset}`.
pub fn section(mesh: &Mesh, normal: DVec3, offset: f64) -> Vec<Polyline> {
    let vertex = |i: u32| DVec3::from(mesh.vertices[i as usize].map(f64::from));
    let s: Vec<f64> = (0..mesh.vertices.len() as u32)
        .map(|i| normal.dot(vertex(i)) - offset)
        .collect();
    let point = |a: u32, b: u32| -> SectionPoint {
        let (sa, sb) = (s[a as usize], s[b as usize]);
        let t = sa / (sa - sb);
        let (pa, pb) = (vertex(a), vertex(b));
        let pos = pa + (pb - pa) * t;
        // Key edges by their smaller vertex so both triangles agree.
        if a < b {
            SectionPoint {
                pos,
                edge: (a, b),
                t,
            }
        } else {
            SectionPoint {
                pos,
                edge: (b, a),
                t: 1.0 - t,
            }
        }
    };
    // segments: (rising point, falling point)
    let mut segs: Vec<(SectionPoint, SectionPoint)> = Vec::new();
    for tri in &mesh.triangles {
        let mut rise = None;
        let mut fall = None;
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (ba, bb) = (s[a as usize] < 0.0, s[b as usize] < 0.0);
            if ba && !bb {
                rise = Some(point(a, b));
            } else if !ba && bb {
                fall = Some(point(a, b));
            }
        }
        if let (Some(r), Some(f)) = (rise, fall) {
            segs.push((r, f));
        }
    }
    let by_start: HashMap<(u32, u32), usize> = segs
        .iter()
        .enumerate()
        .map(|(i, (r, _))| (r.edge, i))
        .collect();
    let ends: std::collections::HashSet<(u32, u32)> = segs.iter().map(|(_, f)| f.edge).collect();
    let mut used = vec![false; segs.len()];
    let mut out = Vec::new();
    // Open chains first (they start on an edge no segment ends on), then loops.
    let starts: Vec<usize> = (0..segs.len())
        .filter(|&i| !ends.contains(&segs[i].0.edge))
        .chain(0..segs.len())
        .collect();
    for i0 in starts {
        if used[i0] {
            continue;
        }
        let mut pts = vec![segs[i0].0];
        let mut i = i0;
        let closed = loop {
            used[i] = true;
            let end = segs[i].1;
            match by_start.get(&end.edge) {
                Some(&j) if j == i0 => break true,
                Some(&j) if !used[j] => {
                    pts.push(end);
                    i = j;
                }
                _ => {
                    pts.push(end);
                    break false;
                }
            }
        };
        out.push(Polyline {
            points: pts,
            closed,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::box_mesh;

    #[test]
    fn a_box_cut_through_the_middle_is_one_closed_square() {
        let b = box_mesh([0.0; 3], [2.0, 2.0, 2.0]);
        let p = section(&b, DVec3::Z, 1.0);
        assert_eq!(p.len(), 1);
        assert!(p[0].closed);
        let perim: f64 = (0..p[0].points.len())
            .map(|i| {
                let a = p[0].points[i].pos;
                let b = p[0].points[(i + 1) % p[0].points.len()].pos;
                a.distance(b)
            })
            .sum();
        assert!((perim - 8.0).abs() < 1e-9, "{perim}");
        assert!(p[0].points.iter().all(|q| (q.pos[2] - 1.0).abs() < 1e-12));
        // Through the bottom face's vertices: they count as above, so the
        // whole box is above and there is no section; through the top
        // face's, the side edges are cut at their top ends.
        assert!(section(&b, DVec3::Z, 0.0).is_empty());
        assert_eq!(section(&b, DVec3::Z, 2.0)[0].points.len(), 8);
        assert!(section(&b, DVec3::Z, 2.5).is_empty());
    }

    #[test]
    fn an_open_surface_gives_open_polylines() {
        let mut b = box_mesh([0.0; 3], [2.0, 2.0, 2.0]);
        b.triangles.truncate(2); // the bottom face only
        let p = section(&b, DVec3::X, 1.0);
        assert_eq!(p.len(), 1);
        assert!(!p[0].closed);
        assert_eq!(p[0].points.len(), 3);
    }
}
