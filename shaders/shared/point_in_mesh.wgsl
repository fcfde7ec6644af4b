// Ray parity with simulation-of-simplicity tie-breaking; mirrors
// src/geometry/point_in_mesh.rs.

fn vless(a: vec3<f32>, b: vec3<f32>) -> bool {
    return a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z < b.z)));
}

fn edge_positive_ordered(a: vec3<f32>, b: vec3<f32>, p: vec3<f32>) -> bool {
    let e = (a.x - p.x) * (b.y - p.y) - (a.y - p.y) * (b.x - p.x);
    if e != 0.0 {
        return e > 0.0;
    }
    let s = a.y - b.y;
    if s != 0.0 {
        return s > 0.0;
    }
    return b.x - a.x > 0.0;
}

// Every edge evaluated from its smaller vertex: shared edges get exactly
// opposite signs whatever the driver fuses.
fn edge_positive(a: vec3<f32>, b: vec3<f32>, p: vec3<f32>) -> bool {
    if vless(b, a) {
        return !edge_positive_ordered(b, a, p);
    }
    return edge_positive_ordered(a, b, p);
}

fn ray_crosses(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, p: vec3<f32>) -> bool {
    let s0 = edge_positive(a, b, p);
    let s1 = edge_positive(b, c, p);
    let s2 = edge_positive(c, a, p);
    if s0 != s1 || s1 != s2 {
        return false;
    }
    let w_c = (a.x - p.x) * (b.y - p.y) - (a.y - p.y) * (b.x - p.x);
    let w_a = (b.x - p.x) * (c.y - p.y) - (b.y - p.y) * (c.x - p.x);
    let w_b = (c.x - p.x) * (a.y - p.y) - (c.y - p.y) * (a.x - p.x);
    let sum = w_a + w_b + w_c;
    if sum == 0.0 {
        return false;
    }
    let num = w_a * (a.z - p.z) + w_b * (b.z - p.z) + w_c * (c.z - p.z);
    if sum > 0.0 {
        return num > 0.0;
    }
    return num < 0.0;
}
