// Bindings and kinematics of the motion kernels (collide_expand,
// collide_reduce), which share one pipeline layout of their own
// (src/collide/gpu/resources.rs). Mirrored by src/collide/cpu/expand.rs,
// which follows src/kinematics/mod.rs in f32.

@group(0) @binding(0) var<uniform> motion: Motion;
@group(0) @binding(1) var<storage, read> moves: array<Move>;
// The batch's queries, as collide_traverse reads them.
@group(0) @binding(2) var<storage, read_write> sample_queries: array<Query>;
// The batch's result words (RESULT_HIT), as collide_exact leaves them.
@group(0) @binding(3) var<storage, read> sample_results: array<u32>;
@group(0) @binding(4) var<storage, read_write> move_results: array<u32>;

const RESULT_HIT_BIT: u32 = 1u;

// kinematics::tip_position (Table I inverted): the part-frame tip at
// machine X, Y, Z and rotary angles t (tilt), c.
fn tip_position(xyz: vec3<f32>, t: f32, c: f32) -> vec3<f32> {
    let st = sin(t);
    let ct = cos(t);
    let sc = sin(c);
    let cc = cos(c);
    let x = xyz.x;
    let y = xyz.y;
    let z = xyz.z;
    let d = motion.d;
    let h = motion.h;
    let r = motion.r;
    let ac = motion.rotary == 1u;
    if motion.configuration == 1u {
        if ac {
            let u = x;
            let v = y + d * st;
            return vec3<f32>(-cc * u + sc * v, sc * u + cc * v, z + d * (1.0 - ct));
        }
        let u = x - d * st;
        let v = y;
        return vec3<f32>(cc * u - sc * v, -sc * u - cc * v, z + d * (1.0 - ct));
    }
    if motion.configuration == 2u {
        if ac {
            return vec3<f32>(x + r * cc - h * sc * st - r, y + r * sc + h * cc * st, z - h * ct + h);
        }
        return vec3<f32>(x - r * sc - h * cc * st, y + r * cc - h * sc * st - r, z - h * ct + h);
    }
    if ac {
        return vec3<f32>(cc * x + ct * sc * y + st * sc * z, -sc * x + ct * cc * y + st * cc * z, -st * y + ct * z);
    }
    return vec3<f32>(ct * cc * x + sc * y - st * cc * z, -ct * sc * x + cc * y + st * sc * z, st * x + ct * z);
}

// The query of the head at tip p with rotary angles t, c
// (kinematics::head_rotation; Query.rows[i] is column i of the rotation,
// the tip in w).
fn pose_query(p: vec3<f32>, t: f32, c: f32, cutoff: u32, margin: f32) -> Query {
    let st = sin(t);
    let ct = cos(t);
    let sc = sin(c);
    let cc = cos(c);
    var q: Query;
    if motion.rotary == 1u {
        q.rows[0] = vec4<f32>(cc, -sc, 0.0, p.x);
        q.rows[1] = vec4<f32>(sc * ct, cc * ct, -st, p.y);
        q.rows[2] = vec4<f32>(sc * st, cc * st, ct, p.z);
    } else {
        q.rows[0] = vec4<f32>(cc * ct, -sc * ct, st, p.x);
        q.rows[1] = vec4<f32>(sc, cc, 0.0, p.y);
        q.rows[2] = vec4<f32>(-cc * st, sc * st, ct, p.z);
    }
    q.cutoff = cutoff;
    q.margin = margin;
    q.slope = 0.0;
    q.pad = 0u;
    return q;
}

// Machine::pose_along: sample k of move m at fraction f = k · inv_n.
fn sample_query(m: Move, k: u32) -> Query {
    let f = f32(k) * m.inv_n;
    let t = m.start.w + f * (m.end.w - m.start.w);
    let c = m.c_from + f * m.c_delta;
    var p: vec3<f32>;
    if motion.interpolation == 1u {
        let a = tip_position(m.start.xyz, m.start.w, m.c_from);
        let b = tip_position(m.end.xyz, m.end.w, m.c_from + m.c_delta);
        p = a + f * (b - a);
    } else {
        p = tip_position(m.start.xyz + f * (m.end.xyz - m.start.xyz), t, c);
    }
    return pose_query(p, t, c, m.cutoff, m.margin);
}
