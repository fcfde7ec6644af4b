//! Axis-aligned boxes: overlap, distance and the triangle–box test used to
//! walk the head's own BVH.

use super::{cross, dot, sub, vmax, vmin, V3};

/// An axis-aligned box, `min <= max` component-wise when non-empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: V3,
    /// Upper corner.
    pub max: V3,
}

impl Aabb {
    /// The empty box (grows from nothing).
    pub const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The box around the given points.
    pub fn from_points(points: &[V3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, p| b.grow(*p))
    }

    /// This box grown to contain `p`.
    pub fn grow(self, p: V3) -> Aabb {
        Aabb {
            min: vmin(self.min, p),
            max: vmax(self.max, p),
        }
    }

    /// The union of two boxes.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: vmin(self.min, o.min),
            max: vmax(self.max, o.max),
        }
    }

    /// True when the closed boxes share a point.
    pub fn overlaps(&self, o: &Aabb) -> bool {
        overlaps(self.min, self.max, o.min, o.max)
    }

    /// Largest side length.
    pub fn extent(&self) -> f32 {
        let d = sub(self.max, self.min);
        d[0].max(d[1]).max(d[2])
    }

    /// Centre point.
    pub fn center(&self) -> V3 {
        [
            (self.min[0] + self.max[0]) * 0.5,
            (self.min[1] + self.max[1]) * 0.5,
            (self.min[2] + self.max[2]) * 0.5,
        ]
    }
}

/// Closed-box overlap of `[amin, amax]` and `[bmin, bmax]`.
#[inline(always)]
pub fn overlaps(amin: V3, amax: V3, bmin: V3, bmax: V3) -> bool {
    amin[0] <= bmax[0]
        && bmin[0] <= amax[0]
        && amin[1] <= bmax[1]
        && bmin[1] <= amax[1]
        && amin[2] <= bmax[2]
        && bmin[2] <= amax[2]
}

/// Euclidean distance from `p` to the box (0 inside).
#[inline(always)]
pub fn point_box_distance(p: V3, bmin: V3, bmax: V3) -> f32 {
    let dx = (bmin[0] - p[0]).max(0.0).max(p[0] - bmax[0]);
    let dy = (bmin[1] - p[1]).max(0.0).max(p[1] - bmax[1]);
    let dz = (bmin[2] - p[2]).max(0.0).max(p[2] - bmax[2]);
    (dx * dx + dy * dy + dz * dz).sqrt()
}

/// Conservative triangle–box overlap: the boxes overlap and the triangle's
/// plane (thickened by `tol`) passes through the box. Used only to prune the
/// head BVH; the exact answer comes from the triangle tests.
#[inline(always)]
pub fn triangle_box_overlap(v0: V3, v1: V3, v2: V3, tol: f32, bmin: V3, bmax: V3) -> bool {
    let tmin = vmin(vmin(v0, v1), v2);
    let tmax = vmax(vmax(v0, v1), v2);
    let lo = [bmin[0] - tol, bmin[1] - tol, bmin[2] - tol];
    let hi = [bmax[0] + tol, bmax[1] + tol, bmax[2] + tol];
    if !overlaps(tmin, tmax, lo, hi) {
        return false;
    }
    // Plane–box: the box's projection radius on the normal against the
    // distance of its centre from the plane.
    let n = cross(sub(v1, v0), sub(v2, v0));
    let c = [
        (lo[0] + hi[0]) * 0.5,
        (lo[1] + hi[1]) * 0.5,
        (lo[2] + hi[2]) * 0.5,
    ];
    let e = [
        (hi[0] - lo[0]) * 0.5,
        (hi[1] - lo[1]) * 0.5,
        (hi[2] - lo[2]) * 0.5,
    ];
    let r = e[0] * n[0].abs() + e[1] * n[1].abs() + e[2] * n[2].abs();
    let s = dot(n, sub(c, v0));
    s.abs() <= r * 1.001
}
