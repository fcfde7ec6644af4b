//! Reading inputs (toolpaths, meshes, machine programs) and writing outputs
//! (programs, plan.csv, toolpath folders) atomically.
//!
//! Every input problem is an [`InputError`] whose message is one line naming
//! the file, the line (or facet) and what to do about it.

pub mod fixed;
pub mod gcode;
pub mod gcode_read;
pub mod gcode_words;
pub mod mesh;
pub mod number;
pub mod obj_plain;
pub mod output;
pub mod plan_csv;
pub mod toolpath_folder;
pub mod waypoint_csv;
pub mod waypoint_file;
pub mod waypoint_line;

use std::path::{Path, PathBuf};

/// A problem with an input file.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A problem at a known line of a text file.
    #[error("{}:{line}: {msg}", path.display())]
    AtLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong and what to do.
        msg: String,
    },
    /// A problem with a file as a whole (or a binary file).
    #[error("{}: {msg}", path.display())]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong and what to do.
        msg: String,
    },
}

impl InputError {
    /// A whole-file error.
    pub fn file(path: &Path, msg: impl Into<String>) -> Self {
        InputError::File {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }

    /// An error at `line` (1-based).
    pub fn at(path: &Path, line: usize, msg: impl Into<String>) -> Self {
        InputError::AtLine {
            path: path.to_path_buf(),
            line,
            msg: msg.into(),
        }
    }
}

/// Read a whole file, mapping failures to a one-line error.
pub fn read_to_string(path: &Path) -> Result<String, InputError> {
    std::fs::read_to_string(path).map_err(|e| {
        InputError::file(
            path,
            format!("cannot read the file ({e}): check the path and permissions"),
        )
    })
}

/// Placement applied to everything in the part frame: optional Y-up → Z-up
/// rotation (+90° about x), then a translation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    /// Convert Y-up input to Z-up.
    pub y_up: bool,
    /// Translation added after the rotation (mm).
    pub offset: [f32; 3],
}

impl Placement {
    /// Apply to a point.
    pub fn point(&self, p: [f32; 3]) -> [f32; 3] {
        let r = self.direction(p);
        [
            r[0] + self.offset[0],
            r[1] + self.offset[1],
            r[2] + self.offset[2],
        ]
    }

    /// Apply to a direction (rotation only).
    pub fn direction(&self, d: [f32; 3]) -> [f32; 3] {
        if self.y_up {
            [d[0], -d[2], d[1]]
        } else {
            d
        }
    }
}
