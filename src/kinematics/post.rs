//! The post-processor: how the machine's controller reads a program (the
//! machine file's `[post]` section). It decides what the G-code says and,
//! as important, what the machine does between two lines — which the
//! planner must check.
//!
//! - **Dialect.** `joint`: machine axes `X Y Z` plus the rotary axes, which
//!   the controller interpolates linearly and together (the data set's
//!   reference G-code); the nozzle tip bows off the bead, so extruding moves
//!   get intermediate points. `g43.4` (Fanuc, LinuxCNC) and `traori`
//!   (Siemens): tool-centre-point control — the words are the tip's
//!   position in the part frame plus the rotary axes, and the controller
//!   moves the tip straight in the part frame while the rotary axes turn
//!   linearly, so no intermediate points are needed. The program switches
//!   TCP on after homing (`G43.4 H<tool>` / `TRAORI`) and off before its
//!   end (`G49` / `TRAFOOF`); the nozzle offset of a second extruder is the
//!   controller's tool data there, not a shift of the written X/Y.
//! - **Rotary axes** as the machine names them: any letter, and a sign
//!   (`-1` where the machine counts the angle the other way).
//! - **Feed**: `g94` (mm/min) or `g93` inverse time (each `G1` line's `F`
//!   is 1 / its planned duration in minutes: the controller then takes
//!   exactly that long, which is how a rotary move gets a correct feed).
//! - **Extruder**: absolute (`M82`) or relative (`M83`), and its letter:
//!   `E` on printers, another axis letter (`A`, `U`, `W`, …) on a CNC
//!   machine converted to print, whose extruder is driven as an axis.
//! - **Work offsets** `G54`–`G59`: where each work coordinate system lies
//!   in the machine's frame (identity unless given), and what `G4 P`
//!   counts in (milliseconds as printers read it, or seconds as CNC
//!   controllers do).

use super::Rotary;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What the program's words mean and how the controller interpolates them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Dialect {
    /// Machine axes, interpolated linearly together (`G1 X Y Z B C E`).
    #[default]
    #[serde(rename = "joint")]
    Joint,
    /// Tool-centre-point control switched on by `G43.4 H<tool>`, off by `G49`.
    #[serde(rename = "g43.4")]
    G43_4,
    /// Tool-centre-point control switched on by `TRAORI`, off by `TRAFOOF`.
    #[serde(rename = "traori")]
    Traori,
}

impl Dialect {
    /// How the controller moves between two lines in this dialect.
    pub fn interpolation(self) -> Interpolation {
        match self {
            Dialect::Joint => Interpolation::Joint,
            Dialect::G43_4 | Dialect::Traori => Interpolation::TipLinear,
        }
    }

    /// The name the machine file uses.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Joint => "joint",
            Dialect::G43_4 => "g43.4",
            Dialect::Traori => "traori",
        }
    }
}

/// What the machine does between two program lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Every machine axis moves linearly from one line's value to the next.
    Joint,
    /// The tip moves straight in the part frame; the rotary axes linearly.
    TipLinear,
}

/// Feed mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum FeedMode {
    /// `G94`: F in mm/min.
    #[default]
    #[serde(rename = "g94")]
    G94,
    /// `G93`: F is the inverse of the line's duration in minutes.
    #[serde(rename = "g93")]
    G93,
}

/// Extruder coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum ExtrusionMode {
    /// `M82`: E is the filament position (reset per layer with `G92 E0`).
    #[default]
    #[serde(rename = "absolute")]
    Absolute,
    /// `M83`: E is the filament advanced by the line.
    #[serde(rename = "relative")]
    Relative,
}

/// What `G4 P` counts in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum DwellUnit {
    /// Milliseconds (Marlin, RepRap: the data set's printer).
    #[default]
    #[serde(rename = "ms")]
    Milliseconds,
    /// Seconds (LinuxCNC, Fanuc with a decimal point).
    #[serde(rename = "s")]
    Seconds,
}

/// The work coordinate systems a program can select, in order.
pub const WORK_SYSTEMS: [&str; 6] = ["G54", "G55", "G56", "G57", "G58", "G59"];

/// The machine file's `[post]` section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Post {
    /// Dialect.
    #[serde(default)]
    pub dialect: Dialect,
    /// Letter of the tilt axis [default: B on B/C machines, A on A/C].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tilt_letter: Option<char>,
    /// Letter of the turning axis [default: C].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c_letter: Option<char>,
    /// `1` or `-1`: the written tilt angle is this times the planned one.
    #[serde(default = "plus")]
    pub tilt_sign: f64,
    /// `1` or `-1`: the written C angle is this times the planned one.
    #[serde(default = "plus")]
    pub c_sign: f64,
    /// Feed mode.
    #[serde(default)]
    pub feed: FeedMode,
    /// Extruder coordinates.
    #[serde(default)]
    pub extrusion: ExtrusionMode,
    /// Letter of the extruder axis [default: E]; any other letter frees
    /// `E` of meaning on this machine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extruder_letter: Option<char>,
    /// What `G4 P` counts in [default: ms]; `G4 S` is always seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dwell_p: Option<DwellUnit>,
    /// `G54`…`G59`: X Y Z of each work coordinate system's origin in the
    /// machine's frame (mm): a program's X Y Z are read as that origin
    /// plus the words, and written as the axes minus `G54`'s. Systems not
    /// given are the machine's frame itself.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub work_offsets: BTreeMap<String, [f64; 3]>,
}

fn plus() -> f64 {
    1.0
}

/// Letters a rotary axis cannot take: the linear axes and the words every
/// dialect uses for something else.
const TAKEN: &str = "XYZEFGMTSNHDPO";

impl Default for Post {
    /// The joint dialect with the machine's own axis names, G94, absolute E:
    /// the data set's reference G-code.
    fn default() -> Post {
        Post {
            dialect: Dialect::Joint,
            tilt_letter: None,
            c_letter: None,
            tilt_sign: 1.0,
            c_sign: 1.0,
            feed: FeedMode::G94,
            extrusion: ExtrusionMode::Absolute,
            extruder_letter: None,
            dwell_p: None,
            work_offsets: BTreeMap::new(),
        }
    }
}

impl Post {
    /// The tilt axis' letter on a machine with rotary pair `rot`.
    pub fn tilt_letter(&self, rot: Rotary) -> char {
        self.tilt_letter.unwrap_or(match rot {
            Rotary::BC => 'B',
            Rotary::AC => 'A',
        })
    }

    /// The turning axis' letter.
    pub fn c_letter(&self) -> char {
        self.c_letter.unwrap_or('C')
    }

    /// The extruder axis' letter.
    pub fn extruder_letter(&self) -> char {
        self.extruder_letter.unwrap_or('E')
    }

    /// What `G4 P` counts in.
    pub fn dwell_unit(&self) -> DwellUnit {
        self.dwell_p.unwrap_or_default()
    }

    /// The origin of work coordinate system `k` (0: `G54`, … 5: `G59`)
    /// in the machine's frame.
    pub fn work_offset(&self, k: usize) -> [f64; 3] {
        WORK_SYSTEMS
            .get(k)
            .and_then(|name| self.work_offsets.get(*name))
            .copied()
            .unwrap_or([0.0; 3])
    }

    /// How the controller moves between two lines.
    pub fn interpolation(&self) -> Interpolation {
        self.dialect.interpolation()
    }

    /// Why this section cannot be used, if it cannot.
    pub fn validate(&self, rot: Rotary) -> Result<(), String> {
        let (t, c) = (self.tilt_letter(rot), self.c_letter());
        for (name, l) in [("post.tilt_letter", t), ("post.c_letter", c)] {
            if !l.is_ascii_uppercase() || TAKEN.contains(l) {
                return Err(format!(
                    "{name} must be an upper-case letter other than {TAKEN} (got '{l}')"
                ));
            }
        }
        if t == c {
            return Err("post.tilt_letter and post.c_letter must differ".into());
        }
        let e = self.extruder_letter();
        if !e.is_ascii_uppercase() || (e != 'E' && TAKEN.contains(e)) {
            return Err(format!(
                "post.extruder_letter must be E or an upper-case letter other than {TAKEN} (got '{e}')"
            ));
        }
        if e == t || e == c {
            return Err(format!(
                "post.extruder_letter '{e}' is also a rotary axis' letter: give post.tilt_letter / post.c_letter another"
            ));
        }
        for (name, v) in &self.work_offsets {
            if !WORK_SYSTEMS.contains(&name.as_str()) {
                return Err(format!(
                    "post.work_offsets.{name}: the work coordinate systems are G54 to G59"
                ));
            }
            if v.iter().any(|x| !x.is_finite()) {
                return Err(format!(
                    "post.work_offsets.{name} must be three finite numbers (mm)"
                ));
            }
        }
        for (name, s) in [
            ("post.tilt_sign", self.tilt_sign),
            ("post.c_sign", self.c_sign),
        ] {
            if s != 1.0 && s != -1.0 {
                return Err(format!("{name} must be 1 or -1"));
            }
        }
        Ok(())
    }
}
