// Möller's triangle–triangle test with a tolerance in millimetres; mirrors
// src/geometry/tri_tri.rs line for line.

struct TriPlane {
    n: vec3<f32>,
    d: f32,
    t: f32,
}

fn tri_plane(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tol: f32) -> TriPlane {
    let n = cross3(v1 - v0, v2 - v0);
    return TriPlane(n, -dot3(n, v0), tol * len3(n));
}

fn snap(d: f32, t: f32) -> f32 {
    if abs(d) < t {
        return 0.0;
    }
    return d;
}

// Where edges from the lone vertex `a` cross the plane: (x0, x1).
fn isect(a: f32, b: f32, c: f32, da: f32, db: f32, dc: f32) -> vec2<f32> {
    return vec2<f32>(a + (b - a) * da / (da - db), a + (c - a) * da / (da - dc));
}

// The interval on the projection axis; .z = 0 when the triangle lies in
// the plane (coplanar case).
fn interval(vv0: f32, vv1: f32, vv2: f32, d0: f32, d1: f32, d2: f32, d0d1: f32, d0d2: f32) -> vec3<f32> {
    if d0d1 > 0.0 {
        return vec3<f32>(isect(vv2, vv0, vv1, d2, d0, d1), 1.0);
    } else if d0d2 > 0.0 {
        return vec3<f32>(isect(vv1, vv0, vv2, d1, d0, d2), 1.0);
    } else if d1 * d2 > 0.0 || d0 != 0.0 {
        return vec3<f32>(isect(vv0, vv1, vv2, d0, d1, d2), 1.0);
    } else if d1 != 0.0 {
        return vec3<f32>(isect(vv1, vv0, vv2, d1, d0, d2), 1.0);
    } else if d2 != 0.0 {
        return vec3<f32>(isect(vv2, vv0, vv1, d2, d0, d1), 1.0);
    }
    return vec3<f32>(0.0, 0.0, 0.0);
}

fn edge_edge(v0: vec2<f32>, v1: vec2<f32>, u0: vec2<f32>, u1: vec2<f32>) -> bool {
    let ax = v1.x - v0.x;
    let ay = v1.y - v0.y;
    let bx = u0.x - u1.x;
    let by = u0.y - u1.y;
    let cx = v0.x - u0.x;
    let cy = v0.y - u0.y;
    let f = ay * bx - ax * by;
    let d = by * cx - bx * cy;
    if (f > 0.0 && d >= 0.0 && d <= f) || (f < 0.0 && d <= 0.0 && d >= f) {
        let e = ax * cy - ay * cx;
        if f > 0.0 {
            if e >= 0.0 && e <= f {
                return true;
            }
        } else if e <= 0.0 && e >= f {
            return true;
        }
    }
    return false;
}

fn edge_against_tri(a: vec2<f32>, b: vec2<f32>, c0: vec2<f32>, c1: vec2<f32>, c2: vec2<f32>) -> bool {
    return edge_edge(a, b, c0, c1) || edge_edge(a, b, c1, c2) || edge_edge(a, b, c2, c0);
}

fn point_in_tri_2d(p: vec2<f32>, a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> bool {
    let e0 = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    let e1 = (c.x - b.x) * (p.y - b.y) - (c.y - b.y) * (p.x - b.x);
    let e2 = (a.x - c.x) * (p.y - c.y) - (a.y - c.y) * (p.x - c.x);
    return (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
}

fn project2(v: vec3<f32>, i0: u32, i1: u32) -> vec2<f32> {
    return vec2<f32>(v[i0], v[i1]);
}

fn coplanar_tri_tri(n: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, u0: vec3<f32>, u1: vec3<f32>, u2: vec3<f32>) -> bool {
    let a = abs(n);
    var i0 = 0u;
    var i1 = 1u;
    if a.x > a.y {
        if a.x > a.z {
            i0 = 1u;
            i1 = 2u;
        }
    } else if !(a.z > a.y) {
        i1 = 2u;
    }
    let pv0 = project2(v0, i0, i1);
    let pv1 = project2(v1, i0, i1);
    let pv2 = project2(v2, i0, i1);
    let pu0 = project2(u0, i0, i1);
    let pu1 = project2(u1, i0, i1);
    let pu2 = project2(u2, i0, i1);
    return edge_against_tri(pv0, pv1, pu0, pu1, pu2) || edge_against_tri(pv1, pv2, pu0, pu1, pu2)
        || edge_against_tri(pv2, pv0, pu0, pu1, pu2) || point_in_tri_2d(pv0, pu0, pu1, pu2)
        || point_in_tri_2d(pu0, pv0, pv1, pv2);
}

// Möller's test of V (the plane's triangle) against U.
fn tri_plane_overlaps(pl: TriPlane, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, u0: vec3<f32>, u1: vec3<f32>, u2: vec3<f32>, tol: f32) -> bool {
    let n1 = pl.n;
    if pl.t == 0.0 {
        return false;
    }
    let du0 = snap(dot3(n1, u0) + pl.d, pl.t);
    let du1 = snap(dot3(n1, u1) + pl.d, pl.t);
    let du2 = snap(dot3(n1, u2) + pl.d, pl.t);
    let du0du1 = du0 * du1;
    let du0du2 = du0 * du2;
    if du0du1 > 0.0 && du0du2 > 0.0 {
        return false;
    }
    let n2 = cross3(u1 - u0, u2 - u0);
    let l2 = len3(n2);
    if l2 == 0.0 {
        return false;
    }
    let d2 = -dot3(n2, u0);
    let t2 = tol * l2;
    let dv0 = snap(dot3(n2, v0) + d2, t2);
    let dv1 = snap(dot3(n2, v1) + d2, t2);
    let dv2 = snap(dot3(n2, v2) + d2, t2);
    let dv0dv1 = dv0 * dv1;
    let dv0dv2 = dv0 * dv2;
    if dv0dv1 > 0.0 && dv0dv2 > 0.0 {
        return false;
    }
    let dd = cross3(n1, n2);
    let ax = abs(dd.x);
    let ay = abs(dd.y);
    let az = abs(dd.z);
    var index = 0u;
    var mx = ax;
    if ay > mx {
        mx = ay;
        index = 1u;
    }
    if az > mx {
        index = 2u;
    }
    let iv = interval(v0[index], v1[index], v2[index], dv0, dv1, dv2, dv0dv1, dv0dv2);
    if iv.z == 0.0 {
        return coplanar_tri_tri(n1, v0, v1, v2, u0, u1, u2);
    }
    let iu = interval(u0[index], u1[index], u2[index], du0, du1, du2, du0du1, du0du2);
    if iu.z == 0.0 {
        return coplanar_tri_tri(n1, v0, v1, v2, u0, u1, u2);
    }
    let a0 = min(iv.x, iv.y);
    let a1 = max(iv.x, iv.y);
    let b0 = min(iu.x, iu.y);
    let b1 = max(iu.x, iu.y);
    return !(a1 < b0 || b1 < a0);
}
