//! Distance from a point to a segment in `f64`: the ground truth's
//! edge-to-edge fallback (`collide::brute`) and the iso-planar generator's
//! chord check both ask it.

use glam::DVec3;

/// Distance from `p` to segment `a b`, the nearest point's parameter
/// clamped to `[0, 1]` (a segment of length 0: the distance to `a`).
pub fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.dot(ab);
    let t = if l2 > 0.0 {
        ((p - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}
