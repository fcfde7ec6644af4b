//! The machine's other bodies as `program.glb` draws them: the meshes a
//! machine file names (`[[display]]`), and the data set's printer's,
//! shipped in the binary (`datasets/zhang2021_machine/`, BSD-3-Clause,
//! its LICENSE beside them).

use crate::geometry::Mesh;
use crate::io::mesh::{load_mesh, read_with_tobj};
use crate::io::InputError;
use crate::kinematics::machine_file::BUILTIN;
use crate::kinematics::{BodyMotion, Machine};
use std::path::PathBuf;

/// The shipped bodies: name under `builtin:` and OBJ text.
const SHIPPED: [(&str, &str); 5] = [
    (
        "zhang2021/base.obj",
        include_str!("../../datasets/zhang2021_machine/base.obj"),
    ),
    (
        "zhang2021/X_axis.obj",
        include_str!("../../datasets/zhang2021_machine/X_axis.obj"),
    ),
    (
        "zhang2021/Y_axis.obj",
        include_str!("../../datasets/zhang2021_machine/Y_axis.obj"),
    ),
    (
        "zhang2021/B_axis.obj",
        include_str!("../../datasets/zhang2021_machine/B_axis.obj"),
    ),
    (
        "zhang2021/Z_axis.obj",
        include_str!("../../datasets/zhang2021_machine/Z_axis.obj"),
    ),
];

/// Each display body of `m` with its mesh.
pub fn machine_bodies(m: &Machine) -> Result<Vec<(BodyMotion, Mesh)>, InputError> {
    m.display
        .iter()
        .map(|b| {
            let mesh = match b.mesh.strip_prefix(BUILTIN) {
                Some(name) => {
                    let unknown = || InputError::File {
                        path: PathBuf::from(&b.mesh),
                        msg: format!(
                            "no such built-in body; the built-in ones are {}",
                            SHIPPED.map(|s| s.0).join(", ")
                        ),
                    };
                    let text = SHIPPED.iter().find(|s| s.0 == name).ok_or_else(unknown)?.1;
                    read_with_tobj(text).expect("the shipped bodies are valid OBJ")
                }
                None => load_mesh(&PathBuf::from(&b.mesh))?,
            };
            Ok((b.moves_with, mesh))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_machine_draws_the_data_sets_printer() {
        let bodies = machine_bodies(&Machine::default()).unwrap();
        assert_eq!(bodies.len(), 5);
        assert!(bodies.iter().all(|(_, m)| m.triangles.len() > 50));
        // The cradle holds the table under the tip (the origin).
        let (_, cradle) = bodies
            .iter()
            .find(|(k, _)| *k == BodyMotion::Cradle)
            .unwrap();
        let z_min = cradle
            .vertices
            .iter()
            .map(|v| v[2])
            .fold(f32::MAX, f32::min);
        assert!(z_min < 0.0, "{z_min}");
    }
}
