// Squared Euclidean distance between two triangles for the safety margin,
// and the closer-than predicate with its plane-separation early outs;
// mirrors src/geometry/tri_tri_distance.rs line for line (vertex-triangle,
// edge-edge and edge-crossing terms; no loops, so the exact kernel's loops
// stay un-nested).

// "No candidate" in a minimum of squared distances (NO_DISTANCE in Rust).
const NO_DISTANCE: f32 = 1e30;

fn clamp01(x: f32) -> f32 {
    return min(max(x, 0.0), 1.0);
}

fn closest_point(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot3(ab, ap);
    let d2 = dot3(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = dot3(ab, bp);
    let d4 = dot3(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = dot3(ab, cp);
    let d6 = dot3(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let sum = va + vb + vc;
    if sum <= 0.0 {
        return a;
    }
    let v = vb / sum;
    let w = vc / sum;
    return (a + ab * v) + ac * w;
}

fn point_triangle_distance_sq(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let x = closest_point(p, a, b, c);
    let d = p - x;
    return dot3(d, d);
}

fn segment_segment_distance_sq(p1: vec3<f32>, q1: vec3<f32>, p2: vec3<f32>, q2: vec3<f32>) -> f32 {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = dot3(d1, d1);
    let e = dot3(d2, d2);
    let f = dot3(d2, r);
    let c = dot3(d1, r);
    let b = dot3(d1, d2);
    var s = 0.0;
    var t = 0.0;
    if a <= 0.0 {
        if e > 0.0 {
            t = clamp01(f / e);
        }
    } else if e <= 0.0 {
        s = clamp01(-c / a);
    } else {
        let denom = a * e - b * b;
        if denom > 0.0 {
            s = clamp01((b * f - c * e) / denom);
        }
        t = (b * s + f) / e;
        if t < 0.0 {
            t = 0.0;
            s = clamp01(-c / a);
        } else if t > 1.0 {
            t = 1.0;
            s = clamp01((b - c) / a);
        }
    }
    let c1 = p1 + d1 * s;
    let c2 = p2 + d2 * t;
    let d = c1 - c2;
    return dot3(d, d);
}

fn edge_crossing_distance_sq(e0: vec3<f32>, e1: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, n: vec3<f32>) -> f32 {
    let s0 = dot3(n, e0 - a);
    let s1 = dot3(n, e1 - a);
    if (s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0) {
        let t = s0 / (s0 - s1);
        let x = e0 + (e1 - e0) * t;
        return point_triangle_distance_sq(x, a, b, c);
    }
    return NO_DISTANCE;
}

fn tri_tri_distance_sq(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, p: vec3<f32>, q: vec3<f32>, r: vec3<f32>) -> f32 {
    var d = point_triangle_distance_sq(a, p, q, r);
    d = min(d, point_triangle_distance_sq(b, p, q, r));
    d = min(d, point_triangle_distance_sq(c, p, q, r));
    d = min(d, point_triangle_distance_sq(p, a, b, c));
    d = min(d, point_triangle_distance_sq(q, a, b, c));
    d = min(d, point_triangle_distance_sq(r, a, b, c));
    d = min(d, segment_segment_distance_sq(a, b, p, q));
    d = min(d, segment_segment_distance_sq(a, b, q, r));
    d = min(d, segment_segment_distance_sq(a, b, r, p));
    d = min(d, segment_segment_distance_sq(b, c, p, q));
    d = min(d, segment_segment_distance_sq(b, c, q, r));
    d = min(d, segment_segment_distance_sq(b, c, r, p));
    d = min(d, segment_segment_distance_sq(c, a, p, q));
    d = min(d, segment_segment_distance_sq(c, a, q, r));
    d = min(d, segment_segment_distance_sq(c, a, r, p));
    let n1 = cross3(b - a, c - a);
    let n2 = cross3(q - p, r - p);
    d = min(d, edge_crossing_distance_sq(a, b, p, q, r, n2));
    d = min(d, edge_crossing_distance_sq(b, c, p, q, r, n2));
    d = min(d, edge_crossing_distance_sq(c, a, p, q, r, n2));
    d = min(d, edge_crossing_distance_sq(p, q, a, b, c, n1));
    d = min(d, edge_crossing_distance_sq(q, r, a, b, c, n1));
    d = min(d, edge_crossing_distance_sq(r, p, a, b, c, n1));
    return d;
}

fn plane_separates(n: vec3<f32>, d: f32, lim: f32, p: vec3<f32>, q: vec3<f32>, r: vec3<f32>) -> bool {
    let sp = dot3(n, p) + d;
    let sq = dot3(n, q) + d;
    let sr = dot3(n, r) + d;
    let lo = min(min(sp, sq), sr);
    let hi = max(max(sp, sq), sr);
    return (lo > 0.0 && lo * lo >= lim) || (hi < 0.0 && hi * hi >= lim);
}

fn tri_tri_closer_than(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, p: vec3<f32>, q: vec3<f32>, r: vec3<f32>, margin: f32) -> bool {
    let m2 = margin * margin;
    let n1 = cross3(b - a, c - a);
    if plane_separates(n1, -dot3(n1, a), m2 * dot3(n1, n1), p, q, r) {
        return false;
    }
    let n2 = cross3(q - p, r - p);
    if plane_separates(n2, -dot3(n2, p), m2 * dot3(n2, n2), a, b, c) {
        return false;
    }
    if edge_axes_separate(a, b, c, p, q, r, m2) {
        return false;
    }
    return tri_tri_distance_sq(a, b, c, p, q, r) < m2;
}

fn edge_axes_separate(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, p: vec3<f32>, q: vec3<f32>, r: vec3<f32>, m2: f32) -> bool {
    let first = array<vec3<f32>, 3>(a, b, c);
    let second = array<vec3<f32>, 3>(p, q, r);
    for (var i = 0u; i < 3u; i++) {
        let u0 = first[i];
        let u1 = first[(i + 1u) % 3u];
        let u2 = first[(i + 2u) % 3u];
        let e = u1 - u0;
        for (var j = 0u; j < 3u; j++) {
            let w0 = second[j];
            let w1 = second[(j + 1u) % 3u];
            let w2 = second[(j + 2u) % 3u];
            let l = cross3(e, w1 - w0);
            let ll = dot3(l, l);
            if ll <= 1e-12 {
                continue;
            }
            let x = dot3(l, u2 - u0);
            let y0 = dot3(l, w0 - u0);
            let y1 = dot3(l, w2 - u0);
            var gap = min(y0, y1) - max(x, 0.0);
            gap = max(gap, min(x, 0.0) - max(y0, y1));
            if gap > 0.0 && gap * gap >= m2 * ll {
                return true;
            }
        }
    }
    return false;
}
