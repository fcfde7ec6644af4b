//! CPU mirror of `shaders/collide_expand.wgsl` (with
//! `shaders/shared/motion.wgsl`): the query of sample `k` of a move, posed
//! in `f32` as the kernel poses it — the machine's interpolation
//! (joint-linear, or the tip straight) and Table I in the order the WGSL
//! spells them. `kinematics` does the same in `f64`; the two agree to
//! `f32` rounding (and the GPU's `sin`/`cos`, which are not the CPU's),
//! tested in `tests/gpu.rs`.

use crate::collide::gpu::wire::{GpuMotion, GpuMove};
use crate::scene::GpuQuery;

/// The part-frame tip at machine X, Y, Z and rotary angles `t` (tilt),
/// `c`.
///
/// Twin: `tip_position` (`motion.wgsl`).
pub fn tip_position(m: &GpuMotion, [x, y, z]: [f32; 3], t: f32, c: f32) -> [f32; 3] {
    let (st, ct) = (t.sin(), t.cos());
    let (sc, cc) = (c.sin(), c.cos());
    let [d, h, r] = m.offsets;
    let ac = m.rotary == 1;
    match m.configuration {
        1 if ac => {
            let (u, v) = (x, y + d * st);
            [-cc * u + sc * v, sc * u + cc * v, z + d * (1.0 - ct)]
        }
        1 => {
            let (u, v) = (x - d * st, y);
            [cc * u - sc * v, -sc * u - cc * v, z + d * (1.0 - ct)]
        }
        2 if ac => [
            x + r * cc - h * sc * st - r,
            y + r * sc + h * cc * st,
            z - h * ct + h,
        ],
        2 => [
            x - r * sc - h * cc * st,
            y + r * cc - h * sc * st - r,
            z - h * ct + h,
        ],
        _ if ac => [
            cc * x + ct * sc * y + st * sc * z,
            -sc * x + ct * cc * y + st * cc * z,
            -st * y + ct * z,
        ],
        _ => [
            ct * cc * x + sc * y - st * cc * z,
            -ct * sc * x + cc * y + st * sc * z,
            st * x + ct * z,
        ],
    }
}

/// The head at tip `p` with rotary angles `t`, `c` (each row of the
/// query is a column of the head's rotation, the tip in the fourth place).
///
/// Twin: `pose_query` (`motion.wgsl`).
pub fn pose_query(
    m: &GpuMotion,
    p: [f32; 3],
    t: f32,
    c: f32,
    cutoff: u32,
    margin: f32,
) -> GpuQuery {
    let (st, ct) = (t.sin(), t.cos());
    let (sc, cc) = (c.sin(), c.cos());
    let rows = if m.rotary == 1 {
        [
            [cc, -sc, 0.0, p[0]],
            [sc * ct, cc * ct, -st, p[1]],
            [sc * st, cc * st, ct, p[2]],
        ]
    } else {
        [
            [cc * ct, -sc * ct, st, p[0]],
            [sc, cc, 0.0, p[1]],
            [-cc * st, sc * st, ct, p[2]],
        ]
    };
    GpuQuery {
        rows,
        cutoff,
        margin,
        slope: 0.0,
        _pad: 0,
    }
}

/// Sample `k` of `mv`, at fraction `k · inv_n` of the move.
///
/// Twin: `sample_query` (`motion.wgsl`).
pub fn sample_query(m: &GpuMotion, mv: &GpuMove, k: u32) -> GpuQuery {
    let f = k as f32 * mv.inv_n;
    let lerp = |a: f32, b: f32| a + f * (b - a);
    let t = lerp(mv.from[3], mv.to[3]);
    let c = mv.c_from + f * mv.c_delta;
    let xyz = |v: [f32; 4]| [v[0], v[1], v[2]];
    let p = if m.interpolation == 1 {
        let a = tip_position(m, xyz(mv.from), mv.from[3], mv.c_from);
        let b = tip_position(m, xyz(mv.to), mv.to[3], mv.c_from + mv.c_delta);
        std::array::from_fn(|i| lerp(a[i], b[i]))
    } else {
        let p = std::array::from_fn(|i| lerp(mv.from[i], mv.to[i]));
        tip_position(m, p, t, c)
    };
    pose_query(m, p, t, c, mv.cutoff, mv.margin)
}

/// The samples of `mv` as the kernel writes them into its query slots.
///
/// Twin: `main` (`collide_expand.wgsl`) for one move.
pub fn samples(m: &GpuMotion, mv: &GpuMove) -> Vec<GpuQuery> {
    (1..=mv.count).map(|k| sample_query(m, mv, k)).collect()
}
