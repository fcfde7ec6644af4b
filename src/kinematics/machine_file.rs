//! The machine file (TOML) and the default machine.
//!
//! The default models the data set's printer: configuration III with a B/C
//! rotary table (the part tilts about Y and turns about Z under a fixed
//! vertical nozzle), offsets 0 (the rotary axes meet at the origin of the
//! part frame after placement), tip speeds [1, 25] mm/s as in paper 000.
//! Axis speed limits: linear 100 mm/s (desktop gantry rapids); rotary
//! 14 °/s (2.3 rpm), in the range of the small worm-gear rotary/tilt tables
//! such printers use (a few rpm), and the value at which the unprocessed
//! simple_curve toolpath misses the tip-speed range as often as paper 000
//! reports before its optimisation (Fig. 10, 17.74 %; BENCHMARKS.md has the
//! calibration curve).

use super::post::Post;
use super::{Configuration, Rotary};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What can go wrong reading a machine file.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    /// Unreadable file.
    #[error("{path}: cannot read the machine file ({source}): check the path", path = .path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Invalid TOML or fields.
    #[error("{path}:{line}: {msg}: fix the machine file (see README, Machine file)", path = .path.display())]
    Parse {
        /// The file.
        path: std::path::PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        msg: String,
    },
}

/// Allowed range and speed of one axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisLimits {
    /// Lowest position (mm or degrees).
    pub min: f64,
    /// Highest position (mm or degrees).
    pub max: f64,
    /// Top speed (mm/s or degrees/s).
    pub speed: f64,
}

/// Extrusion parameters (paper 000, Eq. 1): `ΔE = k · H · W · |Δp|` with
/// the layer height `H` measured per waypoint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Extrusion {
    /// Machine coefficient k (filament mm per mm³ of bead).
    pub k: f64,
    /// Bead width W (mm).
    pub width: f64,
    /// Layer height used where none can be measured (mm).
    pub default_height: f64,
    /// Nozzle temperature (°C) for the G-code header.
    pub temperature: u32,
    /// Tool number of the main extruder (`T<n>` in the G-code).
    #[serde(default = "default_tool")]
    pub tool: u32,
}

fn default_tool() -> u32 {
    1
}

/// The printing settings of one extruder. The machine file's `[support]`
/// section is one: the second extruder that prints support layers (layers
/// named `…S`), as the data set's original software does; the main
/// extruder's come from `[extrusion]` and the machine's feed and tip-speed
/// range ([`Machine::tool_for`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSettings {
    /// Tool number (`T<n>`).
    pub tool: u32,
    /// Nozzle temperature (°C).
    pub temperature: u32,
    /// Print feed (mm/s).
    pub feed: f64,
    /// Extrusion factor on the main extruder's Eq. 1.
    pub extrusion: f64,
    /// X/Y offset of this nozzle from the main one (mm); the written X/Y of
    /// its moves are shifted by minus this.
    pub offset: [f64; 2],
    /// Tip-speed range this extruder can feed (mm/s).
    pub tip_speed: [f64; 2],
}

/// The support extruder's defaults: the data set's reference G-code.
pub fn default_support() -> ToolSettings {
    ToolSettings {
        tool: 2,
        temperature: 205,
        feed: 41.667,
        extrusion: 0.9,
        offset: [0.0, 0.0],
        tip_speed: [1.0, 41.667],
    }
}

/// Moves between printed sections: retract, lift, travel, approach, prime.
/// Defaults are the data set's reference G-code.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Travel {
    /// Filament pulled back before a travel and pushed back after it (mm).
    pub retract: f64,
    /// Feed of retract and prime (mm/s of filament).
    pub retract_speed: f64,
    /// Extra filament pushed at the start of each layer (mm).
    pub prime: f64,
    /// Travel height above the highest machine Z printed so far (mm).
    pub lift: f64,
    /// The head comes down to this height above the next waypoint, then
    /// approaches it along the nozzle (mm).
    pub approach: f64,
    /// Feed of horizontal and rotary travel (mm/s).
    pub speed: f64,
    /// Feed of lifting and lowering (mm/s).
    pub z_speed: f64,
    /// Machine Z of the home / park position (mm).
    pub home_z: f64,
}

impl Default for Travel {
    fn default() -> Self {
        Travel {
            retract: 6.0,
            retract_speed: 80.0,
            prime: 3.0,
            lift: 50.0,
            approach: 2.0,
            speed: 87.5,
            z_speed: 79.167,
            home_z: 230.0,
        }
    }
}

impl Travel {
    /// Seconds a break takes besides its rotation: retract and prime, lift
    /// and lower, approach.
    pub fn break_seconds(&self) -> f64 {
        2.0 * self.retract / self.retract_speed
            + 2.0 * self.lift / self.z_speed
            + self.approach / self.z_speed
    }
}

fn default_margin() -> f64 {
    0.05
}

fn default_tip_tolerance() -> f64 {
    0.05
}

/// A 5-axis machine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    /// Table I configuration.
    pub configuration: Configuration,
    /// Rotary pair.
    pub rotary: Rotary,
    /// Config I: distance from the tip to the tilt axis (mm).
    #[serde(default)]
    pub d: f64,
    /// Config II: distance from the tip to where the axes meet (mm).
    #[serde(default)]
    pub h: f64,
    /// Config II: distance from the tip to the C axis (mm).
    #[serde(default)]
    pub r: f64,
    /// X axis.
    pub x: AxisLimits,
    /// Y axis.
    pub y: AxisLimits,
    /// Z axis.
    pub z: AxisLimits,
    /// Tilt axis (B or A), degrees.
    pub tilt: AxisLimits,
    /// C axis, degrees; the range applies to machines whose cables cannot
    /// wind freely, otherwise leave it out (C turns without limit).
    pub c: CAxis,
    /// Tip speed range [v_min, v_max] the extruder can feed (mm/s).
    pub tip_speed: [f64; 2],
    /// Commanded print feed (mm/s).
    pub feed: f64,
    /// Extrusion.
    pub extrusion: Extrusion,
    /// Safety margin (mm): every pose and move keeps at least this distance
    /// from the platform and printed material.
    #[serde(default = "default_margin")]
    pub margin: f64,
    /// Largest distance the nozzle tip may leave its bead while extruding
    /// under joint-linear interpolation (mm); longer moves get intermediate
    /// points.
    #[serde(default = "default_tip_tolerance")]
    pub tip_tolerance: f64,
    /// The support extruder.
    #[serde(default = "default_support")]
    pub support: ToolSettings,
    /// Moves between printed sections.
    #[serde(default)]
    pub travel: Travel,
    /// How the controller reads the program (dialect, axis letters, feed
    /// and extruder modes).
    #[serde(default)]
    pub post: Post,
}

/// The C axis: speed, and an optional range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CAxis {
    /// Top speed, degrees/s.
    pub speed: f64,
    /// Optional `[min, max]` in degrees.
    #[serde(default)]
    pub range: Option<[f64; 2]>,
}

impl Default for Machine {
    fn default() -> Self {
        Machine {
            configuration: Configuration::III,
            rotary: Rotary::BC,
            d: 0.0,
            h: 0.0,
            r: 0.0,
            x: AxisLimits {
                min: -200.0,
                max: 200.0,
                speed: 100.0,
            },
            y: AxisLimits {
                min: -200.0,
                max: 200.0,
                speed: 100.0,
            },
            z: AxisLimits {
                min: -50.0,
                max: 250.0,
                speed: 100.0,
            },
            tilt: AxisLimits {
                min: -90.0,
                max: 90.0,
                speed: 14.0,
            },
            c: CAxis {
                speed: 14.0,
                range: None,
            },
            tip_speed: [1.0, 25.0],
            feed: 25.0,
            extrusion: Extrusion {
                k: 0.55,
                width: 0.7,
                default_height: 0.5,
                temperature: 205,
                tool: 1,
            },
            margin: default_margin(),
            tip_tolerance: default_tip_tolerance(),
            support: default_support(),
            travel: Travel::default(),
            post: Post::default(),
        }
    }
}

impl Machine {
    /// The extruder printing a layer: the support tool for support layers.
    pub fn tool_for(&self, support: bool) -> ToolSettings {
        if support {
            self.support
        } else {
            ToolSettings {
                tool: self.extrusion.tool,
                temperature: self.extrusion.temperature,
                feed: self.feed,
                extrusion: 1.0,
                offset: [0.0, 0.0],
                tip_speed: self.tip_speed,
            }
        }
    }

    /// Offsets `[d, h, r]`.
    pub fn offsets(&self) -> [f64; 3] {
        [self.d, self.h, self.r]
    }

    /// The default machine as TOML (what `plan --machine` reads).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("machine serialises")
    }

    fn validate(&self) -> Result<(), String> {
        let speeds = [
            self.x.speed,
            self.y.speed,
            self.z.speed,
            self.tilt.speed,
            self.c.speed,
            self.feed,
        ];
        if speeds.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err("every axis speed and the feed must be positive".into());
        }
        let t = &self.travel;
        if [t.retract_speed, t.speed, t.z_speed, self.support.feed]
            .iter()
            .any(|s| !(s.is_finite() && *s > 0.0))
        {
            return Err("travel speeds and the support feed must be positive".into());
        }
        if [t.retract, t.prime, t.lift, t.approach]
            .iter()
            .any(|s| !(s.is_finite() && *s >= 0.0))
        {
            return Err("travel retract, prime, lift and approach must be ≥ 0".into());
        }
        if !(self.margin.is_finite() && self.margin >= 0.0 && self.margin < 10.0) {
            return Err("margin must be between 0 and 10 mm".into());
        }
        if !(self.tip_tolerance.is_finite() && self.tip_tolerance >= 0.001) {
            return Err("tip_tolerance must be at least 0.001 mm".into());
        }
        let [slo, shi] = self.support.tip_speed;
        if !(slo > 0.0 && shi > slo) {
            return Err("support.tip_speed must be [v_min, v_max] with 0 < v_min < v_max".into());
        }
        if let Some([lo, hi]) = self.c.range {
            if lo.is_nan() || hi.is_nan() || lo >= hi {
                return Err("c.range must be [min, max] with min < max".into());
            }
        }
        let [lo, hi] = self.tip_speed;
        if !(lo > 0.0 && hi > lo) {
            return Err("tip_speed must be [v_min, v_max] with 0 < v_min < v_max".into());
        }
        if !(self.travel.home_z >= self.z.min && self.travel.home_z <= self.z.max) {
            return Err("travel.home_z must lie within the z range".into());
        }
        self.post.validate(self.rotary)?;
        for (name, a) in [
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("tilt", self.tilt),
        ] {
            if a.min >= a.max {
                return Err(format!("{name}.min must be below {name}.max"));
            }
        }
        Ok(())
    }
}

/// Read a machine file.
pub fn load_machine(path: &Path) -> Result<Machine, MachineError> {
    let text = std::fs::read_to_string(path).map_err(|source| MachineError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let m: Machine = toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
            .unwrap_or(1);
        let at = text.lines().nth(line - 1).unwrap_or("").trim();
        MachineError::Parse {
            path: path.to_path_buf(),
            line,
            msg: format!("{} (in `{at}`)", e.message().trim()),
        }
    })?;
    m.validate().map_err(|msg| MachineError::Parse {
        path: path.to_path_buf(),
        line: 1,
        msg,
    })?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_round_trips_through_toml() {
        let m = Machine::default();
        let back: Machine = toml::from_str(&m.to_toml()).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn bad_field_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.toml");
        let text = Machine::default()
            .to_toml()
            .replace("feed = 25.0", "feed = \"fast\"");
        std::fs::write(&p, text).unwrap();
        let e = load_machine(&p).unwrap_err().to_string();
        assert!(e.contains("m.toml:") && e.contains("feed"), "{e}");
    }
}
