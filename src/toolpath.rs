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
///
/// A layer whose name ends in `S` (e.g. `12S`) is a support layer: the data
/// set's original software prints it with a second extruder.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layer {
    /// The layer's name (its file stem, e.g. `12` or `12S`).
    pub name: String,
    /// Waypoints in print order.
    pub waypoints: Vec<Waypoint>,
    /// The layer's surface, stamped into the printed-so-far part.
    pub surface: Option<Mesh>,
}

impl Layer {
    /// Is this a support layer (name ending in `S`, as the data set marks them)?
    pub fn is_support(&self) -> bool {
        self.name.ends_with('S')
    }

    /// Share of waypoints whose nozzle direction points down (negative z).
    pub fn downward_share(&self) -> f64 {
        let down = self.waypoints.iter().filter(|w| w.dir[2] < 0.0).count();
        down as f64 / self.waypoints.len().max(1) as f64
    }
}

/// Share of a layer's nozzle directions that must point down before the
/// data set's convention reverses the whole layer (the original software's
/// rule: more than 20 %).
pub const FLIP_SHARE: f64 = 0.2;

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

    /// Every tip position in print order, in f64.
    pub fn positions(&self) -> Vec<[f64; 3]> {
        self.iter().map(|(_, w)| w.pos.map(f64::from)).collect()
    }

    /// Every nozzle direction in print order, in f64.
    pub fn directions(&self) -> Vec<[f64; 3]> {
        self.iter().map(|(_, w)| w.dir.map(f64::from)).collect()
    }

    /// The data set's layer-orientation convention: reverse every nozzle
    /// direction of each layer in which more than [`FLIP_SHARE`] of them
    /// point down (negative z, after any Y-up rotation). Returns the indices
    /// of the layers reversed, in order.
    pub fn flip_downward_layers(&mut self) -> Vec<usize> {
        let mut flipped = Vec::new();
        for (k, l) in self.layers.iter_mut().enumerate() {
            if l.downward_share() > FLIP_SHARE {
                for w in &mut l.waypoints {
                    w.dir = w.dir.map(|c| -c);
                }
                flipped.push(k);
            }
        }
        flipped
    }

    /// Rotate every nozzle direction by `deg` degrees about the x axis (a
    /// stress test: the same toolpath with tilted orientations).
    pub fn tilt_directions(&mut self, deg: f64) {
        let (s, c) = deg.to_radians().sin_cos();
        for l in &mut self.layers {
            for w in &mut l.waypoints {
                let n = w.dir.map(|x| x as f64);
                let r = [n[0], c * n[1] - s * n[2], s * n[1] + c * n[2]];
                let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                w.dir = r.map(|x| (x / len) as f32);
            }
        }
    }

    /// The same waypoints in layers `layer_of` gives (one per waypoint, in
    /// print order, non-decreasing, each within one of this toolpath's
    /// layers). A layer split in parts keeps its name for the first and
    /// its surface for none (a surface belongs to the whole); the others
    /// are named after it, `.1`, `.2`, … (a support layer's `S` kept last);
    /// a toolpath of one layer split into several names them `0`, `1`, ….
    pub fn relayered(&self, layer_of: &[usize]) -> Toolpath {
        let from: Vec<usize> = self.iter().map(|(k, _)| k).collect();
        let waypoints: Vec<Waypoint> = self.iter().map(|(_, w)| *w).collect();
        let mut split = vec![false; self.layers.len()];
        for g in 1..from.len() {
            if from[g] == from[g - 1] && layer_of[g] != layer_of[g - 1] {
                split[from[g]] = true;
            }
        }
        let mut layers: Vec<Layer> = Vec::new();
        let mut part = 0;
        for (g, w) in waypoints.into_iter().enumerate() {
            let new_layer = g == 0 || layer_of[g] != layer_of[g - 1];
            if new_layer {
                let source = &self.layers[from[g]];
                part = if g > 0 && from[g] == from[g - 1] {
                    part + 1
                } else {
                    0
                };
                let split = split[from[g]];
                let name = match (self.layers.len(), part) {
                    (1, _) if split => layers.len().to_string(),
                    (_, 0) => source.name.clone(),
                    _ => match source.name.strip_suffix('S') {
                        Some(base) => format!("{base}.{part}S"),
                        None => format!("{}.{part}", source.name),
                    },
                };
                layers.push(Layer {
                    name,
                    waypoints: Vec::new(),
                    surface: (!split).then(|| source.surface.clone()).flatten(),
                });
            }
            layers.last_mut().expect("a layer").waypoints.push(w);
        }
        Toolpath { layers }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(name: &str, dirs: &[[f32; 3]]) -> Layer {
        Layer {
            name: name.into(),
            waypoints: dirs
                .iter()
                .map(|&dir| Waypoint { pos: [0.0; 3], dir })
                .collect(),
            surface: None,
        }
    }

    #[test]
    fn layers_more_than_a_fifth_down_are_reversed() {
        let up = [0.0, 0.0, 1.0];
        let down = [0.0, 0.6, -0.8];
        let mut tp = Toolpath {
            layers: vec![
                // 1 of 5 down: exactly 20 %, kept.
                layer("0", &[up, up, up, up, down]),
                // 2 of 5 down: reversed, the up ones too.
                layer("1S", &[up, down, up, down, up]),
            ],
        };
        assert_eq!(tp.flip_downward_layers(), vec![1]);
        assert_eq!(tp.layers[0].waypoints[4].dir, down);
        assert_eq!(tp.layers[1].waypoints[0].dir, [0.0, 0.0, -1.0]);
        assert_eq!(tp.layers[1].waypoints[1].dir, [0.0, -0.6, 0.8]);
        assert!(tp.layers[1].is_support() && !tp.layers[0].is_support());
    }

    #[test]
    fn tilt_rotates_about_x() {
        let mut tp = Toolpath {
            layers: vec![layer("0", &[[0.0, 0.0, 1.0]])],
        };
        tp.tilt_directions(90.0);
        let d = tp.layers[0].waypoints[0].dir;
        assert!(d[0].abs() < 1e-6 && (d[1] + 1.0).abs() < 1e-6 && d[2].abs() < 1e-6);
    }
}
