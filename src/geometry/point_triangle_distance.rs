//! Exact closest-point distance from a point to a triangle (Ericson,
//! "Real-Time Collision Detection", 5.1.5), in `f64`. Used once per head to
//! build its distance grid, never per query.

use glam::DVec3;

/// Distance from `p` to triangle `(a, b, c)`.
pub fn point_triangle_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    DVec3::from(p).distance(DVec3::from(closest_point(p, a, b, c)))
}

/// The point of triangle `abc` nearest to `p` (Ericson 5.1.5): a vertex,
/// a point of an edge, or of the face, by the region `p` projects into.
pub fn closest_point(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let [p, a, b, c] = [p, a, b, c].map(DVec3::from);
    let (ab, ac) = (b - a, c - a);
    // The two edges from a vertex against the vector from it to p.
    let edges_to = |v: DVec3| (ab.dot(p - v), ac.dot(p - v));
    let (d1, d2) = edges_to(a);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a.to_array();
    }
    let (d3, d4) = edges_to(b);
    if d3 >= 0.0 && d4 <= d3 {
        return b.to_array();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3))).to_array();
    }
    let (d5, d6) = edges_to(c);
    if d6 >= 0.0 && d5 <= d6 {
        return c.to_array();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6))).to_array();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))).to_array();
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w).to_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert!((point_triangle_distance([0.2, 0.2, 3.0], a, b, c) - 3.0).abs() < 1e-12);
        assert!((point_triangle_distance([-1.0, -1.0, 0.0], a, b, c) - 2f64.sqrt()).abs() < 1e-12);
        assert!((point_triangle_distance([0.5, -2.0, 0.0], a, b, c) - 2.0).abs() < 1e-12);
        assert!((point_triangle_distance([1.0, 1.0, 0.0], a, b, c) - 0.5f64.sqrt()).abs() < 1e-12);
    }
}
