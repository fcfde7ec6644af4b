//! The embedded default job, generated in code so `maamplan check` runs with
//! no input files: a dome printed as four concentric hemispherical shells
//! (curved layers) on a flat platform, with a 45° cone head like the data
//! set's. Near the rim the surface normals are almost horizontal, so the
//! plain orientations drive the head into the platform; at the pole they
//! are vertical, the singular region of a B/C rotary-table machine.
//!
//! The meshes it is made of (a cone or star-shaped head, a box, a height
//! field) are public, for examples and tests.

use crate::geometry::Mesh;
use crate::toolpath::{Layer, Toolpath, Waypoint};
use std::f32::consts::PI;

/// A job's inputs in memory, before any scene is built: a toolpath with
/// its head and platform (`job::LoadedJob` is a job loaded from
/// files, conventions applied and scene built).
#[derive(Clone, Debug)]
pub struct JobInputs {
    /// The toolpath, layer surfaces included.
    pub toolpath: Toolpath,
    /// The head in its own frame.
    pub head: Mesh,
    /// The platform.
    pub platform: Mesh,
}

/// Shells: inner radius, layer height, count, polar extent, spacing.
const R0: f32 = 12.0;
const LAYER_HEIGHT: f32 = 0.8;
const LAYERS: usize = 4;
const THETA_MAX: f32 = 88.0 * PI / 180.0;
const SPACING: f32 = 1.5;

/// The default job's inputs.
pub fn job() -> JobInputs {
    let layers = (0..LAYERS)
        .map(|k| {
            let r = R0 + k as f32 * LAYER_HEIGHT;
            Layer {
                name: k.to_string(),
                waypoints: shell_waypoints(r),
                surface: Some(shell_surface(r)),
            }
        })
        .collect();
    JobInputs {
        toolpath: Toolpath { layers },
        head: default_head(),
        platform: box_mesh([-100.0, -100.0, -5.0], [100.0, 100.0, 0.0]),
    }
}

fn on_sphere(r: f32, theta: f32, phi: f32) -> ([f32; 3], [f32; 3]) {
    let n = [
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    ];
    ([n[0] * r, n[1] * r, n[2] * r], n)
}

/// Rings from the rim up to the pole, each ring in print order; rings are
/// three times denser within 15° of the pole, so each shell spends a few
/// rings inside the singular region.
fn shell_waypoints(r: f32) -> Vec<Waypoint> {
    let fine = 15f32.to_radians();
    let mut thetas = Vec::new();
    let mut theta = THETA_MAX;
    while theta > 0.0 {
        thetas.push(theta);
        theta -= if theta > fine {
            SPACING / r
        } else {
            SPACING / (3.0 * r)
        };
    }
    thetas.push(0.0);
    let mut out = Vec::new();
    for theta in thetas {
        let around = ((2.0 * PI * r * theta.sin()) / SPACING).ceil().max(1.0) as usize;
        for j in 0..around {
            let phi = 2.0 * PI * j as f32 / around as f32;
            let (pos, dir) = on_sphere(r, theta, phi);
            out.push(Waypoint { pos, dir });
        }
    }
    out
}

/// The shell surface: a latitude–longitude grid with a fan at the pole.
fn shell_surface(r: f32) -> Mesh {
    let rings = (THETA_MAX * r / SPACING).ceil() as u32;
    let seg = ((2.0 * PI * r) / SPACING).ceil() as u32;
    let mut m = Mesh::default();
    m.vertices.push([0.0, 0.0, r]);
    for i in 1..=rings {
        let theta = THETA_MAX * i as f32 / rings as f32;
        for j in 0..seg {
            m.vertices
                .push(on_sphere(r, theta, 2.0 * PI * j as f32 / seg as f32).0);
        }
    }
    let at = |i: u32, j: u32| 1 + (i - 1) * seg + (j % seg);
    for j in 0..seg {
        m.triangles.push([0, at(1, j), at(1, j + 1)]);
    }
    for i in 1..rings {
        for j in 0..seg {
            m.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            m.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    m
}

/// The head used where none is given: a 45° cone, 20 mm radius, 30 mm
/// tall, like the data set's.
pub fn default_head() -> Mesh {
    cone_head(20.0, 20.0, 30.0, 64)
}

/// A closed head: a cone of half-angle `atan(radius / cone_height)` from
/// the tip at the origin, then a cylinder up to `height`, axis +z.
pub fn cone_head(radius: f32, cone_height: f32, height: f32, segments: u32) -> Mesh {
    star_head(
        &vec![radius; segments as usize],
        cone_height,
        height,
        [0.0, 0.0],
    )
}

/// A closed head whose cross-section is the star-shaped polygon with
/// `radii` (equally spaced angles, centred at `shift`): a pyramid from the
/// tip at the origin up to `cone_height`, then a prism up to `height`.
/// Unequal radii and a shift make asymmetric, non-convex heads.
pub fn star_head(radii: &[f32], cone_height: f32, height: f32, shift: [f32; 2]) -> Mesh {
    let n = radii.len() as u32;
    let mut m = Mesh::default();
    m.vertices.push([0.0, 0.0, 0.0]); // 0: tip
    m.vertices.push([shift[0], shift[1], height]); // 1: top centre
    for z in [cone_height, height] {
        for (j, r) in radii.iter().enumerate() {
            let a = 2.0 * PI * j as f32 / n as f32;
            m.vertices
                .push([shift[0] + r * a.cos(), shift[1] + r * a.sin(), z]);
        }
    }
    let lo = |j: u32| 2 + (j % n);
    let hi = |j: u32| 2 + n + (j % n);
    for j in 0..n {
        m.triangles.push([0, lo(j + 1), lo(j)]);
        m.triangles.push([lo(j), lo(j + 1), hi(j + 1)]);
        m.triangles.push([lo(j), hi(j + 1), hi(j)]);
        m.triangles.push([1, hi(j), hi(j + 1)]);
    }
    m
}

/// A surface over `[-half_width, half_width]²` with heights `height(x, y)`:
/// `cells` × `cells` squares, each split into four triangles around a
/// vertex at its centre (so the mesh is symmetric under both mirrors),
/// normals up.
pub fn height_field(cells: usize, half_width: f32, height: impl Fn(f32, f32) -> f32) -> Mesh {
    let (n, a) = (cells, half_width);
    let mut m = Mesh::default();
    let h = 2.0 * a / n as f32;
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (-a + i as f32 * h, -a + j as f32 * h);
            m.vertices.push([x, y, height(x, y)]);
        }
    }
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (-a + (i as f32 + 0.5) * h, -a + (j as f32 + 0.5) * h);
            let c = m.vertices.len() as u32;
            m.vertices.push([x, y, height(x, y)]);
            let (p00, p10, p11, p01) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            m.triangles.push([p00, p10, c]);
            m.triangles.push([p10, p11, c]);
            m.triangles.push([p11, p01, c]);
            m.triangles.push([p01, p00, c]);
        }
    }
    m
}

/// A closed axis-aligned box, outward-facing.
pub fn box_mesh(min: [f32; 3], max: [f32; 3]) -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { min[0] } else { max[0] },
                if i & 2 == 0 { min[1] } else { max[1] },
                if i & 4 == 0 { min[2] } else { max[2] },
            ]
        })
        .collect();
    let triangles = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    Mesh {
        vertices,
        triangles,
    }
}

/// The default job's scene at the default settings (for examples,
/// benches and tests).
pub fn scene() -> crate::scene::Scene {
    let job = job();
    crate::scene::Scene::build(
        &job.toolpath,
        &job.head,
        &job.platform,
        &crate::scene::SceneConfig::default(),
    )
    .expect("the default job's scene builds")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_and_platform_are_closed_and_outward() {
        let h = cone_head(20.0, 20.0, 30.0, 32);
        assert_eq!(h.open_edges(), 0);
        assert!(h.signed_volume() > 0.0);
        let b = box_mesh([0.0; 3], [1.0, 2.0, 3.0]);
        assert_eq!(b.open_edges(), 0);
        assert!((b.signed_volume() - 6.0).abs() < 1e-6);
    }

    #[test]
    fn default_job_shape() {
        let j = job();
        assert_eq!(j.toolpath.layers.len(), LAYERS);
        let n = j.toolpath.waypoint_count();
        assert!((500..5000).contains(&n), "{n} waypoints");
        // Passes through the singular region (within 4.5° of vertical).
        let singular = j
            .toolpath
            .iter()
            .filter(|(_, w)| w.dir[2] > 4.5f32.to_radians().cos())
            .count();
        assert!(singular >= 20, "{singular} singular waypoints");
    }
}
