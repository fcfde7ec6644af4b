//! Machine kinematics (paper 000, Table I): the three 5-axis configurations,
//! each with a B/C or A/C rotary pair; inverse kinematics with both
//! solutions (Eqs. 3–4) and forward kinematics, and the head's pose in the
//! part frame that follows from the axes.
//!
//! Conventions (radians inside, degrees at interfaces):
//! - The part-frame nozzle direction of rotary angles `(t, c)` (t = B or A):
//!   B/C: `n = (−sin B cos C, sin B sin C, cos B)`;
//!   A/C: `n = (sin A sin C, sin A cos C, cos A)`.
//!   Both follow from configuration III's Table I rows (the part turns by
//!   `R_y(B)·R_z(C)` or `R_x(A)·R_z(C)` under a vertical nozzle), checked
//!   against the data set's reference G-code; the other configurations
//!   share them, so every machine maps a waypoint to the same two angle
//!   pairs `(t, c)` and `(−t, c + π)`.
//! - The head's rotation in the part frame is `R_z(−C)·R_y(−B)` (A/C:
//!   `R_z(−C)·R_x(−A)`), so the second IK solution is the first turned by π
//!   about the nozzle axis: one collision query for a head with that
//!   symmetry, two otherwise.
//! - Linear axes are Table I transcribed; configuration I's X/Y block is a
//!   mirror as printed (a table axis moving the other way).

pub mod machine_file;
pub mod post;

pub use machine_file::{
    load_machine, AxisLimits, BodyMotion, DisplayBody, Extrusion, Machine, MachineError,
    ToolSettings, Travel,
};
pub use post::{Dialect, DwellUnit, ExtrusionMode, FeedMode, Interpolation, Post};

use crate::geometry::{Pose, V3};
use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Table I's configurations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Configuration {
    /// Rotating table (C) and tilting head (B or A).
    I,
    /// Rotating and tilting head; the part stays put.
    II,
    /// Rotating and tilting table under a fixed vertical nozzle (the data set's machine).
    III,
}

/// Which rotary pair the machine has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rotary {
    /// Tilt about Y (B), turn about Z (C).
    BC,
    /// Tilt about X (A), turn about Z (C).
    AC,
}

/// Machine axis values: linear (mm) and rotary (radians).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Axes {
    /// X, Y, Z (mm).
    pub xyz: [f64; 3],
    /// The tilt axis, B or A (radians).
    pub tilt: f64,
    /// C (radians), unwound where a path says so.
    pub c: f64,
}

/// Wrap an angle into (−π, π].
pub fn wrap(a: f64) -> f64 {
    // `%` is a software fmod, dear in the planner's inner loops; it
    // returns an angle within a turn unchanged, and most are.
    let mut a = if a.abs() < 2.0 * PI {
        a
    } else {
        a % (2.0 * PI)
    };
    if a <= -PI {
        a += 2.0 * PI;
    } else if a > PI {
        a -= 2.0 * PI;
    }
    a
}

/// The nozzle direction (part frame) for rotary angles `(tilt, c)`.
pub fn orientation(rot: Rotary, tilt: f64, c: f64) -> [f64; 3] {
    let (st, ct) = tilt.sin_cos();
    let (sc, cc) = c.sin_cos();
    match rot {
        Rotary::BC => [-st * cc, st * sc, ct],
        Rotary::AC => [st * sc, st * cc, ct],
    }
}

/// Both IK solutions `(tilt, c)` for unit direction `n`: the first with
/// `tilt ≤ 0`, the second `(−tilt, c + π)` wrapped. At the pole (`n = +z`)
/// C is undetermined and returned as 0.
pub fn ik_angles(rot: Rotary, n: [f64; 3]) -> [(f64, f64); 2] {
    let t = n[2].clamp(-1.0, 1.0).acos();
    // Solution with tilt = −t.
    let c = match rot {
        // n = (sin t cos C, −sin t sin C, cos t) for B = −t.
        Rotary::BC => (-n[1]).atan2(n[0]),
        // n = (−sin t sin C, −sin t cos C, cos t) for A = −t.
        Rotary::AC => (-n[0]).atan2(-n[1]),
    };
    let c = if t == 0.0 { 0.0 } else { c };
    [(-t, wrap(c)), (t, wrap(c + PI))]
}

/// The head's rotation in the part frame (head frame → part frame).
pub fn head_rotation(rot: Rotary, tilt: f64, c: f64) -> DMat3 {
    match rot {
        Rotary::BC => DMat3::from_rotation_z(-c) * DMat3::from_rotation_y(-tilt),
        Rotary::AC => DMat3::from_rotation_z(-c) * DMat3::from_rotation_x(-tilt),
    }
}

/// Configuration III's table rotation `R_y(B)·R_z(C)` (A/C: `R_x(A)·R_z(C)`):
/// part frame → machine frame.
fn table_rotation(rot: Rotary, t: f64, c: f64) -> DMat3 {
    match rot {
        Rotary::BC => DMat3::from_rotation_y(t) * DMat3::from_rotation_z(c),
        Rotary::AC => DMat3::from_rotation_x(t) * DMat3::from_rotation_z(c),
    }
}

/// The head pose in the part frame for tip `p` and rotary angles.
pub fn head_pose(rot: Rotary, p: [f64; 3], tilt: f64, c: f64) -> Pose {
    let m = head_rotation(rot, tilt, c);
    let col = |j: usize| m.col(j).as_vec3().to_array();
    Pose {
        cols: [col(0), col(1), col(2)],
        tip: p.map(|x| x as f32),
    }
}

/// The terms of Table I's rows `[d, h, r, sin t, cos t, sin c, cos c]`:
/// the machine's offsets `d` (config I: tip to tilt axis), `h` (config
/// II: tip to the axes' intersection) and `r` (config II: tip to the C
/// axis), and the sines and cosines of the tilt `t` and of C.
fn table_terms(m: &Machine, t: f64, c: f64) -> [f64; 7] {
    let [d, h, r] = m.offsets();
    let (st, ct) = t.sin_cos();
    let (sc, cc) = c.sin_cos();
    [d, h, r, st, ct, sc, cc]
}

/// Table I: `m`'s machine X, Y, Z for part-frame tip `p` at rotary angles
/// `(t, c)`.
pub fn linear_axes(m: &Machine, p: [f64; 3], t: f64, c: f64) -> [f64; 3] {
    let [d, h, r, st, ct, sc, cc] = table_terms(m, t, c);
    let [px, py, pz] = p;
    match (m.configuration, m.rotary) {
        (Configuration::I, Rotary::BC) => [
            px * cc - py * sc + d * st,
            -px * sc - py * cc,
            pz - d * (1.0 - ct),
        ],
        (Configuration::I, Rotary::AC) => [
            -px * cc + py * sc,
            px * sc + py * cc - d * st,
            pz - d * (1.0 - ct),
        ],
        (Configuration::II, Rotary::BC) => [
            px + r * sc + h * cc * st,
            py - r * cc + h * sc * st + r,
            pz + h * ct - h,
        ],
        (Configuration::II, Rotary::AC) => [
            px - r * cc + h * sc * st + r,
            py - r * sc - h * cc * st,
            pz + h * ct - h,
        ],
        (Configuration::III, _) => (table_rotation(m.rotary, t, c) * DVec3::from(p)).to_array(),
    }
}

/// The inverse of [`linear_axes`]: the part-frame tip for machine X, Y, Z.
pub fn tip_position(m: &Machine, xyz: [f64; 3], t: f64, c: f64) -> [f64; 3] {
    let [d, h, r, st, ct, sc, cc] = table_terms(m, t, c);
    let [x, y, z] = xyz;
    match (m.configuration, m.rotary) {
        (Configuration::I, Rotary::BC) => {
            // [x − d st, y] = [[cc, −sc], [−sc, −cc]] [px, py]; that matrix is its own inverse.
            let (u, v) = (x - d * st, y);
            [cc * u - sc * v, -sc * u - cc * v, z + d * (1.0 - ct)]
        }
        (Configuration::I, Rotary::AC) => {
            // [x, y + d st] = [[−cc, sc], [sc, cc]] [px, py]; also an involution.
            let (u, v) = (x, y + d * st);
            [-cc * u + sc * v, sc * u + cc * v, z + d * (1.0 - ct)]
        }
        (Configuration::II, Rotary::BC) => [
            x - r * sc - h * cc * st,
            y + r * cc - h * sc * st - r,
            z - h * ct + h,
        ],
        (Configuration::II, Rotary::AC) => [
            x + r * cc - h * sc * st - r,
            y + r * sc + h * cc * st,
            z - h * ct + h,
        ],
        (Configuration::III, _) => {
            (table_rotation(m.rotary, t, c).transpose() * DVec3::from(xyz)).to_array()
        }
    }
}

/// The point a fraction `t` of the way from `a` to `b`.
fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    let (a, b) = (DVec3::from(a), DVec3::from(b));
    (a + (b - a) * t).to_array()
}

/// Decimals of every axis value in the written program (mm and degrees).
pub const DECIMALS: i32 = 3;

/// `x` rounded to the program's [`DECIMALS`].
pub fn round_written(x: f64) -> f64 {
    let s = 10f64.powi(DECIMALS);
    (x * s).round() / s
}

/// An angle (radians) rounded to the program's [`DECIMALS`] in degrees.
pub fn round_angle(a: f64) -> f64 {
    round_written(a.to_degrees()).to_radians()
}

impl Axes {
    /// The same axes rounded as the G-code writes them, so that what the
    /// planner checks is exactly what the machine is told.
    pub fn as_written(&self) -> Axes {
        Axes {
            xyz: self.xyz.map(round_written),
            tilt: round_angle(self.tilt),
            c: round_angle(self.c),
        }
    }

    /// Linear interpolation `self → b` at `t` (what a controller does
    /// between two G-code lines in the joint-space dialect).
    pub fn lerp(&self, b: &Axes, t: f64) -> Axes {
        Axes {
            xyz: lerp(self.xyz, b.xyz, t),
            tilt: self.tilt + t * (b.tilt - self.tilt),
            c: self.c + t * (b.c - self.c),
        }
    }

    /// Total rotary motion `|Δtilt| + |ΔC|` to `b` (radians).
    pub fn rotation_to(&self, b: &Axes) -> f64 {
        (b.tilt - self.tilt).abs() + (b.c - self.c).abs()
    }
}

impl Machine {
    /// The machine axes putting the tip at part-frame `p` with rotary
    /// angles `(tilt, c)`, rounded as written.
    pub fn axes_at(&self, p: [f64; 3], (tilt, c): (f64, f64)) -> Axes {
        let (tilt, c) = (round_angle(tilt), round_angle(c));
        Axes {
            xyz: linear_axes(self, p, tilt, c).map(round_written),
            tilt,
            c,
        }
    }

    /// The part-frame tip of `a` (forward kinematics).
    pub fn tip(&self, a: &Axes) -> [f64; 3] {
        tip_position(self, a.xyz, a.tilt, a.c)
    }

    /// The head's pose in the part frame at axes `a`: the pose every
    /// command checks (the machine's own, not a minimal rotation).
    pub fn pose(&self, a: &Axes) -> Pose {
        head_pose(self.rotary, self.tip(a), a.tilt, a.c)
    }

    /// The head's pose at fraction `t` of the move `a → b` as this
    /// machine's controller interpolates it ([`Post::interpolation`]):
    /// joint-linear axes, or the tip straight in the part frame with the
    /// rotary axes linear.
    pub fn pose_along(&self, a: &Axes, b: &Axes, t: f64) -> Pose {
        // The rotary axes move linearly in every dialect.
        let r = a.lerp(b, t);
        head_pose(self.rotary, self.tip_along(a, b, t), r.tilt, r.c)
    }

    /// The part-frame tip at fraction `t` of the move `a → b` (see
    /// [`Machine::pose_along`]).
    pub fn tip_along(&self, a: &Axes, b: &Axes, t: f64) -> [f64; 3] {
        match self.post.interpolation() {
            Interpolation::Joint => self.tip(&a.lerp(b, t)),
            Interpolation::TipLinear => lerp(self.tip(a), self.tip(b), t),
        }
    }
}

/// Inverse kinematics of one waypoint: both machine solutions.
pub fn inverse(m: &Machine, p: V3, n: V3) -> [Axes; 2] {
    let p = p.map(|x| x as f64);
    let l = (n[0] as f64).hypot(n[1] as f64).hypot(n[2] as f64);
    let n = n.map(|x| x as f64 / l);
    ik_angles(m.rotary, n).map(|(t, c)| Axes {
        xyz: linear_axes(m, p, t, c),
        tilt: t,
        c,
    })
}

/// Forward kinematics: the part-frame tip and nozzle direction of `a`.
pub fn forward(m: &Machine, a: &Axes) -> ([f64; 3], [f64; 3]) {
    (
        tip_position(m, a.xyz, a.tilt, a.c),
        orientation(m.rotary, a.tilt, a.c),
    )
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn machines() -> Vec<Machine> {
        let mut v = Vec::new();
        for cfg in [Configuration::I, Configuration::II, Configuration::III] {
            for rot in [Rotary::BC, Rotary::AC] {
                v.push(Machine {
                    configuration: cfg,
                    rotary: rot,
                    d: 31.0,
                    h: 47.0,
                    r: 12.5,
                    ..Machine::default()
                });
            }
        }
        v
    }

    #[test]
    fn ik_fk_round_trips_all_variants_including_near_singular() {
        let dirs: Vec<[f64; 3]> = vec![
            [0.3, -0.4, 0.8],
            [-0.9, 0.1, 0.2],
            [0.0, 0.0, 1.0],
            [1e-7, -2e-7, 1.0],
            [0.01, 0.002, 0.9999],
            [-0.5, -0.5, -0.2],
            [0.0, 1.0, 0.0],
        ];
        for m in machines() {
            for d in &dirs {
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let n = d.map(|x| (x / l) as f32);
                let p = [12.5f32, -7.25, 43.0];
                let sols = inverse(&m, p, n);
                for a in &sols {
                    let (q, nn) = forward(&m, a);
                    for k in 0..3 {
                        assert!(
                            (q[k] - p[k] as f64).abs() < 1e-9,
                            "{:?} {:?}: tip {q:?}",
                            m.configuration,
                            m.rotary
                        );
                        assert!(
                            (nn[k] - n[k] as f64).abs() < 1e-6,
                            "{:?} {:?}: dir {nn:?} vs {n:?}",
                            m.configuration,
                            m.rotary
                        );
                    }
                    // The head pose's axis is the nozzle direction.
                    let pose = head_pose(m.rotary, q, a.tilt, a.c);
                    for k in 0..3 {
                        assert!((pose.cols[2][k] - n[k]).abs() < 1e-5);
                    }
                }
                // The two solutions differ by a half-turn about the axis.
                let r0 = head_rotation(m.rotary, sols[0].tilt, sols[0].c);
                let r1 = head_rotation(m.rotary, sols[1].tilt, sols[1].c);
                assert!((r0.x_axis + r1.x_axis).abs().max_element() < 1e-9);
                assert!((r0.y_axis + r1.y_axis).abs().max_element() < 1e-9);
                assert!((r0.z_axis - r1.z_axis).abs().max_element() < 1e-9);
            }
        }
    }

    #[test]
    fn config_iii_bc_matches_the_reference_gcode() {
        // simple_curve waypoint 0 of layer 0 and the reference's G1 for it
        // (B 0, C 0): machine XYZ = part position.
        let m = Machine::default();
        let a = Axes {
            xyz: [0.0; 3],
            tilt: 0.0,
            c: 0.0,
        };
        let p = [1.46518, -14.9918, 40.736649];
        let x = linear_axes(&m, p, a.tilt, a.c);
        assert!(
            (x[0] - 1.465).abs() < 1e-3
                && (x[1] + 14.992).abs() < 1e-3
                && (x[2] - 40.737).abs() < 1e-3
        );
        // A tilted one: B = 8.705°, C = 1.347° maps the waypoint to the
        // reference's X −5.505, Y 5.981, Z 43.811 (within its smoothing).
        let p = [-11.9286, 6.26282, 1.97323 + 40.5];
        let x = linear_axes(&m, p, 8.705f64.to_radians(), 1.347f64.to_radians());
        assert!(
            (x[0] + 5.505).abs() < 0.05
                && (x[1] - 5.981).abs() < 0.05
                && (x[2] - 43.811).abs() < 0.05,
            "{x:?}"
        );
    }
}
