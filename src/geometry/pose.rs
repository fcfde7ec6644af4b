//! Head poses: a rotation (head frame → part frame) and the tip position.
//!
//! For the waypoint's own orientation we use the minimal rotation taking the
//! head axis `+z` onto the nozzle direction (as FCL's cross-check does); the
//! planner later builds poses from machine axes instead, which matters for
//! asymmetric heads.

use super::V3;
use glam::DVec3;

/// A rigid head pose: `x_part = rot * x_head + tip`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Columns of the rotation matrix (images of the head's x, y, z axes).
    pub cols: [V3; 3],
    /// Nozzle tip position in the part frame (mm).
    pub tip: V3,
}

impl Pose {
    /// The minimal rotation taking `+z` onto `axis` (normalised here), placed
    /// at `tip`. `axis = -z` maps to a half-turn about `x`.
    pub fn from_axis(tip: V3, axis: V3) -> Pose {
        let n = to64(axis);
        let n = n / n.length();
        let c = n[2];
        let m: [[f64; 3]; 3] = if c > 1.0 - 1e-12 {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        } else if c < -1.0 + 1e-12 {
            [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
        } else {
            // Rodrigues about a = z × n / |z × n| with sin s, cos c.
            let a = [-n[1], n[0], 0.0];
            let s = (a[0] * a[0] + a[1] * a[1]).sqrt();
            let k = [a[0] / s, a[1] / s, 0.0];
            let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
            let mut r = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    let kk: f64 = (0..3).map(|l| kx[i][l] * kx[l][j]).sum();
                    r[i][j] = if i == j { 1.0 } else { 0.0 } + s * kx[i][j] + (1.0 - c) * kk;
                }
            }
            r
        };
        // m is row-major R; store columns.
        let col = |j: usize| [m[0][j] as f32, m[1][j] as f32, m[2][j] as f32];
        Pose {
            cols: [col(0), col(1), col(2)],
            tip,
        }
    }

    /// The nozzle axis (image of `+z`).
    pub fn axis(&self) -> V3 {
        self.cols[2]
    }

    /// Head-frame point to part frame.
    pub fn to_part(&self, h: V3) -> V3 {
        let c = &self.cols;
        [
            c[0][0] * h[0] + c[1][0] * h[1] + c[2][0] * h[2] + self.tip[0],
            c[0][1] * h[0] + c[1][1] * h[1] + c[2][1] * h[2] + self.tip[1],
            c[0][2] * h[0] + c[1][2] * h[1] + c[2][2] * h[2] + self.tip[2],
        ]
    }

    /// Part-frame point to head frame: `Rᵀ (p − tip)`. This exact sequence
    /// of operations is what the backends and shaders use.
    #[inline(always)]
    pub fn to_head(&self, p: V3) -> V3 {
        let d = [p[0] - self.tip[0], p[1] - self.tip[1], p[2] - self.tip[2]];
        let c = &self.cols;
        [
            c[0][0] * d[0] + c[0][1] * d[1] + c[0][2] * d[2],
            c[1][0] * d[0] + c[1][1] * d[1] + c[1][2] * d[2],
            c[2][0] * d[0] + c[2][1] * d[1] + c[2][2] * d[2],
        ]
    }

    /// The nozzle axis tilted by `tilt` radians towards azimuth `azimuth`
    /// (measured in the plane normal to the axis), as a new pose at the same
    /// tip. Used to sample candidate orientations around a waypoint.
    pub fn tilted(&self, tilt: f64, azimuth: f64) -> Pose {
        let n = to64(self.axis());
        let n = n / n.length();
        // Any unit vector orthogonal to n, then a second one.
        let helper = if n[0].abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let u = n.cross(helper);
        let u = u / u.length();
        let v = n.cross(u);
        let (st, ct) = tilt.sin_cos();
        let (sa, ca) = azimuth.sin_cos();
        let d = n * ct + (u * ca + v * sa) * st;
        Pose::from_axis(self.tip, d.as_vec3().to_array())
    }
}

fn to64(v: V3) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: V3, b: V3) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-5)
    }

    #[test]
    fn axis_maps_z_to_normal_and_round_trips() {
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 2.0, 3.0],
            [0.3, -0.9, 0.1],
        ] {
            let p = Pose::from_axis([1.0, 2.0, 3.0], n);
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!(close(p.axis(), [n[0] / l, n[1] / l, n[2] / l]));
            let h = [0.3, -0.2, 5.0];
            assert!(close(p.to_head(p.to_part(h)), h));
        }
    }

    #[test]
    fn tilt_angle_is_respected() {
        let p = Pose::from_axis([0.0; 3], [0.2, 0.1, 0.9]);
        let t = p.tilted(0.5, 1.3);
        let c: f32 = (0..3).map(|i| p.axis()[i] * t.axis()[i]).sum();
        assert!((c - 0.5f32.cos()).abs() < 1e-5);
    }
}
