// Vector helpers and box tests, mirroring src/geometry/{mod,aabb}.rs: every
// sum is spelled out in the same order as the Rust code.

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

fn len3(a: vec3<f32>) -> f32 {
    return sqrt(dot3(a, a));
}

fn boxes_overlap(amin: vec3<f32>, amax: vec3<f32>, bmin: vec3<f32>, bmax: vec3<f32>) -> bool {
    return amin.x <= bmax.x && bmin.x <= amax.x && amin.y <= bmax.y && bmin.y <= amax.y
        && amin.z <= bmax.z && bmin.z <= amax.z;
}

fn point_box_distance(p: vec3<f32>, bmin: vec3<f32>, bmax: vec3<f32>) -> f32 {
    let dx = max(max(bmin.x - p.x, 0.0), p.x - bmax.x);
    let dy = max(max(bmin.y - p.y, 0.0), p.y - bmax.y);
    let dz = max(max(bmin.z - p.z, 0.0), p.z - bmax.z);
    return sqrt(dx * dx + dy * dy + dz * dz);
}

fn triangle_box_overlap(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tol: f32, bmin: vec3<f32>, bmax: vec3<f32>) -> bool {
    let tmin = min(min(v0, v1), v2);
    let tmax = max(max(v0, v1), v2);
    let lo = bmin - vec3<f32>(tol);
    let hi = bmax + vec3<f32>(tol);
    if !boxes_overlap(tmin, tmax, lo, hi) {
        return false;
    }
    let n = cross3(v1 - v0, v2 - v0);
    let c = (lo + hi) * 0.5;
    let e = (hi - lo) * 0.5;
    let r = e.x * abs(n.x) + e.y * abs(n.y) + e.z * abs(n.z);
    let s = dot3(n, c - v0);
    return abs(s) <= r * 1.001;
}
