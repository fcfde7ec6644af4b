//! Toolpath generators: turn a mesh into waypoints that `plan` and `check`
//! read.
//!
//! - [`slice`](mod@slice): planar slices of a closed mesh along any direction (paper
//!   003), each filled on a grid with a zig-zag, one-way or MZZ raster
//!   ([`fill`]); the nozzle points along the slicing direction.
//! - [`isoplanar`](mod@isoplanar): deposition-rate-optimal iso-planar paths on one curved
//!   layer surface (paper 001), nozzle along the surface normal.
//!
//! Shared pieces: [`validate`] (the mesh checks every generator runs first),
//! [`section`] (a plane cut through a mesh as polylines) and [`curvature`]
//! (per-vertex normals and normal curvatures from local quadric fits).

pub mod curvature;
pub mod fill;
pub mod isoplanar;
pub mod section;
pub mod slice;
pub mod validate;

pub use fill::Fill;
pub use isoplanar::{isoplanar, IsoplanarOptions, IsoplanarResult};
pub use slice::{slice, SliceOptions, SliceResult};

/// What can go wrong generating a toolpath. Every variant is a problem with
/// the input mesh or the parameters (exit code 2 through the CLI).
#[derive(Debug, thiserror::Error)]
pub enum GenerateError {
    /// The mesh has zero-area triangles.
    #[error("{count} degenerate (zero-area) triangles, the first is triangle {first}: remove them and re-close the mesh in a mesh editor")]
    Degenerate {
        /// How many.
        count: usize,
        /// 0-based index of the first one.
        first: usize,
    },
    /// An edge is shared by more than two triangles.
    #[error("the mesh is non-manifold ({count} edges shared by more than two triangles, e.g. between vertices {a} and {b}): split or repair it so every edge has at most two triangles")]
    NonManifold {
        /// How many such edges.
        count: usize,
        /// One end of the first one (0-based vertex index).
        a: u32,
        /// The other end.
        b: u32,
    },
    /// Neighbouring triangles wind in opposite directions.
    #[error("the mesh's triangles are inconsistently oriented ({count} edges used twice in the same direction): make the winding consistent")]
    Inconsistent {
        /// How many such edges.
        count: usize,
    },
    /// A closed mesh was needed.
    #[error("the mesh is not closed ({count} edges with only one triangle): slicing needs a watertight solid; close its holes")]
    Open {
        /// How many boundary edges.
        count: usize,
    },
    /// The mesh encloses no volume, or faces inwards.
    #[error("the mesh is inside out or flat (volume {volume:.3} mm³): flip its triangle winding")]
    InsideOut {
        /// The signed volume.
        volume: f64,
    },
    /// The mesh has no triangles or non-finite coordinates.
    #[error("{0}")]
    Empty(String),
    /// A parameter is out of range.
    #[error("{0}")]
    Parameter(String),
}
