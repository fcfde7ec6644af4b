//! The toolpath: waypoints (tip position + nozzle direction) layer by layer,
//! each layer optionally with the curved surface it is printed on.

use crate::geometry::{Mesh, V3};

/// One waypoint: nozzle tip position and unit nozzle direction (pointing
/// from the tip up into the head), part frame, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waypoint {
    /// Tip position.
    pub pos: V3,
    /// Unit nozzle direction.
    pub dir: V3,
}

/// One layer in print order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layer {
    /// The layer's name (its file stem, e.g. `12` or `12S`).
    pub name: String,
    /// Waypoints in print order.
    pub waypoints: Vec<Waypoint>,
    /// The layer's surface, stamped into the printed-so-far part.
    pub surface: Option<Mesh>,
}

/// A whole toolpath.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Toolpath {
    /// Layers in print order.
    pub layers: Vec<Layer>,
}

impl Toolpath {
    /// Total number of waypoints.
    pub fn waypoint_count(&self) -> usize {
        self.layers.iter().map(|l| l.waypoints.len()).sum()
    }

    /// All waypoints in print order with their layer index.
    pub fn iter(&self) -> impl Iterator<Item = (usize, &Waypoint)> {
        self.layers
            .iter()
            .enumerate()
            .flat_map(|(k, l)| l.waypoints.iter().map(move |w| (k, w)))
    }

    /// Global index of each layer's first waypoint.
    pub fn layer_offsets(&self) -> Vec<usize> {
        let mut acc = 0;
        self.layers
            .iter()
            .map(|l| {
                let o = acc;
                acc += l.waypoints.len();
                o
            })
            .collect()
    }
}
