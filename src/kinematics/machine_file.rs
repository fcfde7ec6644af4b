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
use serde::{Deserialize, Deserializer, Serialize};
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
#[serde(deny_unknown_fields, default)]
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
    pub tool: u32,
}

impl Default for Extrusion {
    /// The data set's printer: a 0.7 mm bead, 0.5 mm layers where none
    /// can be measured, 205 °C, tool 1.
    fn default() -> Self {
        Extrusion {
            k: 0.55,
            width: 0.7,
            default_height: 0.5,
            temperature: 205,
            tool: 1,
        }
    }
}

/// The printing settings of one extruder. The machine file's `[support]`
/// section is one: the second extruder that prints support layers (layers
/// named `…S`), as the data set's original software does; the main
/// extruder's come from `[extrusion]` and the machine's feed and tip-speed
/// range ([`Machine::tool_for`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default = "default_support")]
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
#[serde(deny_unknown_fields, default)]
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

/// A 5-axis machine. Every field the file leaves out, and every field of
/// a section it gives in part, is the default machine's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Machine {
    /// Table I configuration.
    pub configuration: Configuration,
    /// Rotary pair.
    pub rotary: Rotary,
    /// Config I: distance from the tip to the tilt axis (mm).
    pub d: f64,
    /// Config II: distance from the tip to where the axes meet (mm).
    pub h: f64,
    /// Config II: distance from the tip to the C axis (mm).
    pub r: f64,
    /// X axis.
    #[serde(deserialize_with = "x_axis")]
    pub x: AxisLimits,
    /// Y axis.
    #[serde(deserialize_with = "y_axis")]
    pub y: AxisLimits,
    /// Z axis.
    #[serde(deserialize_with = "z_axis")]
    pub z: AxisLimits,
    /// Tilt axis (B or A), degrees.
    #[serde(deserialize_with = "tilt_axis")]
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
    pub margin: f64,
    /// Largest distance the nozzle tip may leave its bead while extruding
    /// under joint-linear interpolation (mm); longer moves get intermediate
    /// points.
    pub tip_tolerance: f64,
    /// The support extruder.
    pub support: ToolSettings,
    /// Moves between printed sections.
    pub travel: Travel,
    /// How the controller reads the program (dialect, axis letters, feed
    /// and extruder modes).
    pub post: Post,
    /// The machine's other bodies, drawn in `program.glb` (no check
    /// involves them). A file that leaves this out draws none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub display: Vec<DisplayBody>,
}

/// A body of the machine drawn as the program runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplayBody {
    /// Its mesh in the machine's home frame (all axes at 0, the tip at the
    /// origin): a mesh file, relative to the machine file, or
    /// `builtin:zhang2021/<name>.obj`, the data set's printer's bodies
    /// shipped with maamplan.
    pub mesh: String,
    /// How it moves.
    pub moves_with: BodyMotion,
}

/// How a [`DisplayBody`] moves with the axes. `x`, `xy` and `cradle` are
/// the carriages of a rotary-table machine (configuration III): a point
/// `p` goes to `p − (X, 0, 0)`, `p − (X, Y, 0)` and `R_tilt p − (X, Y, 0)`;
/// `table` moves as the part does, `head` as the head does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BodyMotion {
    /// Stands still.
    Base,
    /// The X carriage.
    X,
    /// The Y carriage (on the X carriage).
    Xy,
    /// The tilting cradle (on the Y carriage; does not turn with C).
    Cradle,
    /// With the part.
    Table,
    /// With the head.
    Head,
}

/// Prefix of a [`DisplayBody::mesh`] shipped with maamplan.
pub const BUILTIN: &str = "builtin:";

/// The data set's printer's bodies (`datasets/zhang2021_machine/`).
fn zhang2021_bodies() -> Vec<DisplayBody> {
    [
        ("base", BodyMotion::Base),
        ("X_axis", BodyMotion::X),
        ("Y_axis", BodyMotion::Xy),
        ("B_axis", BodyMotion::Cradle),
        ("Z_axis", BodyMotion::Head),
    ]
    .into_iter()
    .map(|(name, moves_with)| DisplayBody {
        mesh: format!("{BUILTIN}zhang2021/{name}.obj"),
        moves_with,
    })
    .collect()
}

/// The C axis: speed, and an optional range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CAxis {
    /// Top speed, degrees/s.
    pub speed: f64,
    /// Optional `[min, max]` in degrees.
    pub range: Option<[f64; 2]>,
}

impl Default for CAxis {
    /// 14 °/s, winding freely.
    fn default() -> Self {
        CAxis {
            speed: 14.0,
            range: None,
        }
    }
}

/// An axis section as a file may give it: a field left out keeps the
/// default machine's value for that axis.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisFields {
    min: Option<f64>,
    max: Option<f64>,
    speed: Option<f64>,
}

/// The axis section of `d`, its missing fields from `default`.
fn axis_or<'de, D: Deserializer<'de>>(d: D, default: AxisLimits) -> Result<AxisLimits, D::Error> {
    let f = AxisFields::deserialize(d)?;
    Ok(AxisLimits {
        min: f.min.unwrap_or(default.min),
        max: f.max.unwrap_or(default.max),
        speed: f.speed.unwrap_or(default.speed),
    })
}

fn x_axis<'de, D: Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    axis_or(d, Machine::default().x)
}

fn y_axis<'de, D: Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    axis_or(d, Machine::default().y)
}

fn z_axis<'de, D: Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    axis_or(d, Machine::default().z)
}

fn tilt_axis<'de, D: Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    axis_or(d, Machine::default().tilt)
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
            c: CAxis::default(),
            tip_speed: [1.0, 25.0],
            feed: 25.0,
            extrusion: Extrusion::default(),
            margin: 0.05,
            tip_tolerance: 0.05,
            support: default_support(),
            travel: Travel::default(),
            post: Post::default(),
            display: zhang2021_bodies(),
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

    /// How far from the part frame's origin a tip the machine can put
    /// within its axis ranges may lie, at most (mm): the linear axes turn
    /// the tip about the origin (or carry it unturned), shifted by lever
    /// arms no longer than twice the offsets, so a tip farther than the
    /// farthest corner of the X, Y, Z ranges plus that is out of range in
    /// every orientation (plus a millimetre for the written rounding).
    pub fn reach(&self) -> f64 {
        let far = |a: &AxisLimits| a.min.abs().max(a.max.abs());
        let corner = far(&self.x).hypot(far(&self.y)).hypot(far(&self.z));
        corner + 2.0 * (self.d.abs() + self.h.abs() + self.r.abs()) + 1.0
    }

    /// The default machine as TOML (what `plan --machine` reads).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("machine serialises")
    }

    /// Check the values serde cannot: `Err` names the fields at fault
    /// (dotted paths, the one to point at first) and what is wrong.
    fn validate(&self) -> Result<(), Invalid> {
        let bad = |keys: &[&str], msg: &str| {
            Err(Invalid {
                keys: keys.iter().map(|k| k.to_string()).collect(),
                msg: msg.to_string(),
            })
        };
        let t = &self.travel;
        for (key, s) in [
            ("x.speed", self.x.speed),
            ("y.speed", self.y.speed),
            ("z.speed", self.z.speed),
            ("tilt.speed", self.tilt.speed),
            ("c.speed", self.c.speed),
            ("feed", self.feed),
            ("travel.retract_speed", t.retract_speed),
            ("travel.speed", t.speed),
            ("travel.z_speed", t.z_speed),
            ("support.feed", self.support.feed),
        ] {
            if !(s.is_finite() && s > 0.0) {
                return bad(&[key], &format!("{key} must be positive"));
            }
        }
        for (key, s) in [
            ("travel.retract", t.retract),
            ("travel.prime", t.prime),
            ("travel.lift", t.lift),
            ("travel.approach", t.approach),
        ] {
            if !(s.is_finite() && s >= 0.0) {
                return bad(&[key], &format!("{key} must be ≥ 0"));
            }
        }
        if !(self.margin.is_finite() && self.margin >= 0.0 && self.margin < 10.0) {
            return bad(&["margin"], "margin must be between 0 and 10 mm");
        }
        if !(self.tip_tolerance.is_finite() && self.tip_tolerance >= 0.001) {
            return bad(
                &["tip_tolerance"],
                "tip_tolerance must be at least 0.001 mm",
            );
        }
        let [slo, shi] = self.support.tip_speed;
        if !(slo > 0.0 && shi > slo) {
            return bad(
                &["support.tip_speed"],
                "support.tip_speed must be [v_min, v_max] with 0 < v_min < v_max",
            );
        }
        if let Some([lo, hi]) = self.c.range {
            if lo.is_nan() || hi.is_nan() || lo >= hi {
                return bad(&["c.range"], "c.range must be [min, max] with min < max");
            }
        }
        let [lo, hi] = self.tip_speed;
        if !(lo > 0.0 && hi > lo) {
            return bad(
                &["tip_speed"],
                "tip_speed must be [v_min, v_max] with 0 < v_min < v_max",
            );
        }
        if !(self.travel.home_z >= self.z.min && self.travel.home_z <= self.z.max) {
            return bad(
                &["travel.home_z", "z.min", "z.max"],
                "travel.home_z must lie within the z range",
            );
        }
        if let Err(msg) = self.post.validate(self.rotary) {
            // Post's messages begin with the field they are about.
            let key = msg.split_whitespace().next().unwrap_or("post").to_string();
            return Err(Invalid {
                keys: vec![key, "post".into()],
                msg,
            });
        }
        self.validate_display()?;
        for (name, a) in [
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("tilt", self.tilt),
        ] {
            if a.min >= a.max {
                let (min, max) = (format!("{name}.min"), format!("{name}.max"));
                return bad(&[&min, &max], &format!("{min} must be below {max}"));
            }
        }
        Ok(())
    }
}

impl Machine {
    /// The carriages of a rotary table (x, xy, cradle) only on one.
    fn validate_display(&self) -> Result<(), Invalid> {
        if self.configuration == Configuration::III {
            return Ok(());
        }
        let carriage = |b: &&DisplayBody| {
            matches!(
                b.moves_with,
                BodyMotion::X | BodyMotion::Xy | BodyMotion::Cradle
            )
        };
        match self.display.iter().find(carriage) {
            None => Ok(()),
            Some(b) => Err(Invalid {
                keys: vec!["display".into()],
                msg: format!(
                    "display body {}: moves_with = x, xy or cradle needs configuration III (use base, table or head)",
                    b.mesh
                ),
            }),
        }
    }
}

/// A machine whose values are out of range: the fields at fault (dotted
/// paths into the file, the one to point at first) and what is wrong.
struct Invalid {
    keys: Vec<String>,
    msg: String,
}

/// The 1-based line in `text` of the first of `keys` (dotted paths such as
/// `tilt.min`) the file gives, else of the nearest section it gives on
/// their way (`[tilt]`), else 1: a value the file leaves to the default is
/// pointed at where the file could set it.
fn line_of(text: &str, keys: &[String]) -> usize {
    let Ok(doc) = toml::de::DeTable::parse(text) else {
        return 1;
    };
    let line = |at: usize| text[..at.min(text.len())].matches('\n').count() + 1;
    let sections = keys.iter().filter_map(|k| k.rsplit_once('.').map(|s| s.0));
    keys.iter()
        .map(String::as_str)
        .chain(sections)
        .find_map(|k| key_start(doc.get_ref(), k))
        .map_or(1, line)
}

/// Where the dotted `key` is written in `table` (the byte offset of its
/// last part's name), if it is.
fn key_start(table: &toml::de::DeTable, key: &str) -> Option<usize> {
    let (head, rest) = match key.split_once('.') {
        Some((h, r)) => (h, Some(r)),
        None => (key, None),
    };
    let (k, v) = table.iter().find(|(k, _)| k.get_ref() == head)?;
    match (rest, v.get_ref()) {
        (None, _) => Some(k.span().start),
        (Some(r), toml::de::DeValue::Table(t)) => key_start(t, r),
        (Some(_), _) => None,
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
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
            .unwrap_or(1);
        let at = text.lines().nth(line - 1).unwrap_or("").trim();
        MachineError::Parse {
            path: path.to_path_buf(),
            line,
            msg: format!("{} (in `{at}`)", e.message().trim()),
        }
    })?;
    let mut m = m;
    m.validate().map_err(|e| MachineError::Parse {
        path: path.to_path_buf(),
        line: line_of(&text, &e.keys),
        msg: e.msg,
    })?;
    let folder = path.parent().unwrap_or(Path::new(""));
    for body in &mut m.display {
        if body.mesh.starts_with(BUILTIN) {
            continue;
        }
        let file = folder.join(&body.mesh);
        if !file.is_file() {
            return Err(MachineError::Parse {
                path: path.to_path_buf(),
                line: line_of(&text, &["display".to_string()]),
                msg: format!(
                    "display mesh {} not found (a path relative to the machine file)",
                    file.display()
                ),
            });
        }
        body.mesh = file.to_string_lossy().into_owned();
    }
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
    fn no_tip_within_the_axis_ranges_lies_beyond_reach() {
        use crate::kinematics::{tip_position, Configuration, Rotary};
        for configuration in [Configuration::I, Configuration::II, Configuration::III] {
            for rotary in [Rotary::BC, Rotary::AC] {
                let m = Machine {
                    configuration,
                    rotary,
                    d: 31.0,
                    h: -12.0,
                    r: 17.0,
                    ..Machine::default()
                };
                let reach = m.reach() - 1.0;
                let mut farthest = 0f64;
                for corner in 0..8 {
                    let pick = |bit: usize, a: &AxisLimits| {
                        if corner >> bit & 1 == 0 {
                            a.min
                        } else {
                            a.max
                        }
                    };
                    let xyz = [pick(0, &m.x), pick(1, &m.y), pick(2, &m.z)];
                    for i in 0..=36 {
                        for j in 0..=36 {
                            let t = (-90.0 + 5.0 * i as f64).to_radians();
                            let c = (10.0 * j as f64).to_radians();
                            let p = tip_position(&m, xyz, t, c);
                            farthest = farthest.max(p[0].hypot(p[1]).hypot(p[2]));
                        }
                    }
                }
                assert!(
                    farthest <= reach + 1e-9,
                    "{configuration:?} {rotary:?}: {farthest} > {reach}"
                );
                assert!(farthest > reach - 2.0 * (31.0 + 12.0 + 17.0) - 1e-9);
            }
        }
    }

    /// The error of loading `text` as a machine file, and the line of
    /// the text's first line that contains `needle` (after `after`).
    fn error_and_line(text: &str, after: &str, needle: &str) -> (String, usize) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.toml");
        std::fs::write(&p, text).unwrap();
        let e = load_machine(&p).unwrap_err().to_string();
        let from = text.lines().position(|l| l.starts_with(after)).unwrap();
        let at = from
            + text
                .lines()
                .skip(from)
                .position(|l| l.starts_with(needle))
                .unwrap();
        (e, at + 1)
    }

    #[test]
    fn bad_field_names_the_line() {
        let text = Machine::default()
            .to_toml()
            .replace("feed = 25.0", "feed = \"fast\"");
        let (e, line) = error_and_line(&text, "", "feed =");
        assert!(
            e.contains(&format!("m.toml:{line}:")) && e.contains("feed"),
            "{e}"
        );
    }

    #[test]
    fn a_value_out_of_range_names_its_line() {
        let default = Machine::default().to_toml();
        let text = default.replacen("min = -90.0", "min = 120.0", 1);
        let (e, line) = error_and_line(&text, "[tilt]", "min =");
        assert!(
            line > 1 && e.contains(&format!("m.toml:{line}: tilt.min")),
            "{e}"
        );
        let text = default.replace("speed = 87.5", "speed = 0.0");
        let (e, line) = error_and_line(&text, "[travel]", "speed =");
        assert!(e.contains(&format!("m.toml:{line}: travel.speed")), "{e}");
        // Left to the default, home_z is pointed at through its section.
        let text = "[travel]\nlift = 5.0\n[z]\nmax = 100.0\n";
        let (e, line) = error_and_line(text, "", "[z]");
        assert!(
            e.contains(&format!("m.toml:{}: travel.home_z", line + 1)),
            "{e}"
        );
    }

    #[test]
    fn display_bodies_are_found_beside_the_machine_file_or_refused_at_their_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("cradle.obj"), "v 0 0 0\n").unwrap();
        let p = dir.path().join("m.toml");
        let body = "[[display]]\nmesh = \"cradle.obj\"\nmoves_with = \"cradle\"\n";
        std::fs::write(&p, format!("margin = 0.1\n{body}")).unwrap();
        let m = load_machine(&p).unwrap();
        assert_eq!(m.display.len(), 1);
        let beside = dir.path().join("cradle.obj");
        assert_eq!(m.display[0].mesh, beside.to_string_lossy());
        assert_eq!(m.display[0].moves_with, BodyMotion::Cradle);
        // Missing: the error names the display section's line.
        let text = format!("margin = 0.1\n{}", body.replace("cradle.obj", "gone.obj"));
        let (e, line) = error_and_line(&text, "", "[[display]]");
        assert!(
            e.contains(&format!("m.toml:{line}:")) && e.contains("gone.obj"),
            "{e}"
        );
        // A carriage of a rotary table on a machine without one.
        let text = format!("configuration = \"II\"\n{body}");
        let (e, _) = error_and_line(&text, "", "[[display]]");
        assert!(e.contains("needs configuration III"), "{e}");
    }

    #[test]
    fn every_field_defaults() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.toml");
        std::fs::write(&p, "").unwrap();
        // All but the drawn bodies: a file's machine is not the data set's
        // printer unless it says so.
        let drawn_none = Machine {
            display: Vec::new(),
            ..Machine::default()
        };
        assert_eq!(load_machine(&p).unwrap(), drawn_none);
        let text = "[tilt]\nmin = -60.0\n[extrusion]\nwidth = 0.5\n[support]\ntool = 3\n[c]\nrange = [-360.0, 360.0]\n";
        std::fs::write(&p, text).unwrap();
        let m = load_machine(&p).unwrap();
        let d = Machine::default();
        assert_eq!(
            m.tilt,
            AxisLimits {
                min: -60.0,
                ..d.tilt
            }
        );
        assert_eq!(
            m.extrusion,
            Extrusion {
                width: 0.5,
                ..d.extrusion
            }
        );
        assert_eq!(
            m.support,
            ToolSettings {
                tool: 3,
                ..d.support
            }
        );
        assert_eq!(
            m.c,
            CAxis {
                range: Some([-360.0, 360.0]),
                ..d.c
            }
        );
        assert_eq!(
            (m.configuration, m.rotary, m.x),
            (d.configuration, d.rotary, d.x)
        );
    }
}
