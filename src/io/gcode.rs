//! G-code for the machine's controller, in the dialect its machine file's
//! `[post]` section names ([`crate::kinematics::Post`]), and reading any
//! such program back.
//!
//! The default is the joint-space dialect of the data set's reference
//! output (`reference_gcode/simple_curve_Gcode.txt`): absolute positions,
//! `G1 X Y Z B C E` while printing (A for the tilt on A/C machines), E
//! absolute and reset per layer with `G92 E0`, travels as `G0`, tool
//! changes as `T<n>` followed by `M109`. The tool-centre-point dialects
//! (`G43.4`, `TRAORI`) write the tip's part-frame position instead of the
//! machine's X Y Z, between an on and an off code; `G93` writes every `G1`
//! line's feed as the inverse of its planned duration in minutes; relative
//! E writes each line's filament (`M83`). A comment header names
//! maamplan's version, the dialect, the machine, the source and the
//! command. Every value is written with three decimals — the values the
//! planner checked ([`crate::kinematics::DECIMALS`]).
//!
//! [`read_program`] reads any program in these dialects back (ours or the
//! reference's) as the motion a controller would make.

use crate::kinematics::{Axes, Dialect, ExtrusionMode, FeedMode, Interpolation, Machine, Post};
use crate::plan::program::{move_seconds, Move, MoveKind, Program, Step, TravelItem};
use std::fmt::Write;

/// What the header says about the run.
#[derive(Clone, Debug, Default)]
pub struct GcodeHeader {
    /// The toolpath planned.
    pub source: String,
    /// The command line.
    pub command: String,
}

/// `x` with three decimals, never `-0.000`.
fn f3(x: f64) -> String {
    let s = super::fixed::fixed(x + 0.0, 3);
    if s == "-0.000" {
        "0.000".into()
    } else {
        s
    }
}

/// Feed in mm/min as the controller reads it (whole numbers where the
/// machine file's mm/s are a whole number of mm/min to 0.05).
fn feed(mm_s: f64) -> String {
    let f = mm_s * 60.0;
    if (f - f.round()).abs() < 0.05 {
        format!("{}", f.round() as i64)
    } else {
        format!("{f:.1}")
    }
}

/// An inverse-time feed (1/min) with seven significant digits, so that the
/// duration it encodes is the planned one to 1e-6.
fn inverse_time(seconds: f64) -> String {
    let f = 60.0 / seconds.max(1e-9);
    let digits = (6 - f.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{f:.digits$}")
}

/// The code that switches tool-centre-point control on for `tool`.
fn tcp_on(dialect: Dialect, tool: u32) -> Option<String> {
    match dialect {
        Dialect::Joint => None,
        Dialect::G43_4 => Some(format!("G43.4 H{tool}")),
        Dialect::Traori => Some("TRAORI".into()),
    }
}

struct Writer<'a> {
    m: &'a Machine,
    post: &'a Post,
    out: String,
    tilt: char,
    c: char,
    feed: Option<String>,
    /// Extruder position as the program last left it.
    e: f64,
}

impl Writer<'_> {
    fn tcp(&self) -> bool {
        self.post.interpolation() == Interpolation::TipLinear
    }

    /// The position words of `a`: machine X Y Z (shifted by minus the
    /// nozzle offset), or the part-frame tip when `tip` (tool-centre-point
    /// control on); then the rotary axes.
    fn axes_words(&self, a: &Axes, offset: [f64; 2], tip: bool) -> String {
        let xyz = if tip {
            self.m.tip(a)
        } else {
            [a.xyz[0] - offset[0], a.xyz[1] - offset[1], a.xyz[2]]
        };
        format!(
            "X{} Y{} Z{} {}{} {}{}",
            f3(xyz[0]),
            f3(xyz[1]),
            f3(xyz[2]),
            self.tilt,
            f3(self.post.tilt_sign * a.tilt.to_degrees()),
            self.c,
            f3(self.post.c_sign * a.c.to_degrees())
        )
    }

    /// ` F…` when the feed changes (G94), or every `G1` line's inverse
    /// time (G93: `seconds` of the line; rapids take none).
    fn feed_word(&mut self, mm_s: f64, rapid: bool, seconds: impl FnOnce() -> f64) -> String {
        if self.post.feed == FeedMode::G93 {
            return if rapid {
                String::new()
            } else {
                format!(" F{}", inverse_time(seconds()))
            };
        }
        let f = feed(mm_s);
        if self.feed.as_deref() == Some(f.as_str()) {
            String::new()
        } else {
            self.feed = Some(f.clone());
            format!(" F{f}")
        }
    }

    /// ` E…` for a line that leaves the extruder at `e`.
    fn e_word(&mut self, e: f64) -> String {
        let w = match self.post.extrusion {
            ExtrusionMode::Absolute => f3(e),
            ExtrusionMode::Relative => f3(e - self.e),
        };
        self.e = e;
        format!("E{w}")
    }

    fn line(&mut self, from: &Axes, mv: &Move) {
        let moves_axes = !matches!(mv.kind, MoveKind::Retract | MoveKind::Prime);
        if moves_axes && mv.to == *from && mv.kind != MoveKind::Print {
            return; // Already there (e.g. no lift needed at the start).
        }
        let words = self.axes_words(&mv.to, mv.offset, self.tcp());
        let rapid = matches!(mv.kind, MoveKind::Lift | MoveKind::Lower | MoveKind::Travel);
        let (m, e) = (self.m, self.e);
        let f = self.feed_word(mv.feed, rapid, || {
            move_seconds(m, from, &mv.to, mv.feed, mv.e - e)
        });
        let _ = match mv.kind {
            MoveKind::Print => {
                let e = self.e_word(mv.e);
                writeln!(self.out, "G1 {words} {e}{f}")
            }
            MoveKind::Retract | MoveKind::Prime => {
                let e = self.e_word(mv.e);
                writeln!(self.out, "G1 {e}{f}")
            }
            MoveKind::Lift | MoveKind::Lower
                if !self.tcp()
                    && mv.to.xyz[0] == from.xyz[0]
                    && mv.to.xyz[1] == from.xyz[1]
                    && mv.to.tilt == from.tilt
                    && mv.to.c == from.c =>
            {
                writeln!(self.out, "G0 Z{}{f}", f3(mv.to.xyz[2]))
            }
            MoveKind::Lift | MoveKind::Lower | MoveKind::Travel => {
                writeln!(self.out, "G0 {words}{f}")
            }
            MoveKind::Approach => writeln!(self.out, "G1 {words}{f}"),
        };
    }

    fn header(&mut self, header: &GcodeHeader) {
        let (m, post, t, c) = (self.m, self.post, self.tilt, self.c);
        let what = match post.dialect {
            Dialect::Joint => format!("joint-space G-code: G1 X Y Z {t} {c} E (machine axes, mm, degrees)"),
            Dialect::G43_4 => format!("tool-centre-point G-code (G43.4): G1 X Y Z {t} {c} E (tip in the part frame, mm, degrees)"),
            Dialect::Traori => format!("tool-centre-point G-code (TRAORI): G1 X Y Z {t} {c} E (tip in the part frame, mm, degrees)"),
        };
        let e = match post.extrusion {
            ExtrusionMode::Absolute => "absolute E reset per layer",
            ExtrusionMode::Relative => "relative E",
        };
        let f = match post.feed {
            FeedMode::G94 => "feed in mm/min",
            FeedMode::G93 => "inverse-time feed (G93)",
        };
        let _ = writeln!(
            self.out,
            "; maamplan {} — {what}, {e}, {f}",
            env!("CARGO_PKG_VERSION")
        );
        let _ = writeln!(
            self.out,
            "; machine: configuration {:?} {:?}, post {} (tilt {t} ×{}, C {c} ×{}), print feed {} mm/s, tip speed {:?} mm/s, margin {} mm, tip tolerance {} mm",
            m.configuration, m.rotary, post.dialect.name(), post.tilt_sign, post.c_sign, m.feed, m.tip_speed, m.margin, m.tip_tolerance
        );
        let _ = writeln!(
            self.out,
            "; tools: T{} main {} °C, T{} support {} °C ({:.1} mm/s, ×{} extrusion)",
            m.extrusion.tool,
            m.extrusion.temperature,
            m.support.tool,
            m.support.temperature,
            m.support.feed,
            m.support.extrusion
        );
        if !header.source.is_empty() {
            let _ = writeln!(self.out, "; source: {}", header.source);
        }
        if !header.command.is_empty() {
            let _ = writeln!(self.out, "; command: {}", header.command);
        }
    }
}

/// The whole program for machine `m`, in the dialect of `m.post`.
pub fn write_gcode(m: &Machine, prog: &Program, header: &GcodeHeader) -> String {
    let post = &m.post;
    let mut w = Writer {
        m,
        post,
        out: String::with_capacity(prog.steps.len() * 56 + 1024),
        tilt: post.tilt_letter(m.rotary),
        c: post.c_letter(),
        feed: None,
        e: 0.0,
    };
    w.header(header);
    let relative = post.extrusion == ExtrusionMode::Relative;
    let _ = writeln!(w.out, "G90\n{}", if relative { "M83" } else { "M82" });
    if post.feed == FeedMode::G93 {
        let _ = writeln!(w.out, "G93");
    }
    if let Some(t) = prog.first_tool {
        let _ = writeln!(w.out, "M104 S{} T{}", t.temperature, t.tool);
    }
    // Homing is in machine coordinates in every dialect.
    let home = prog.home;
    let f = w.feed_word(m.travel.speed, true, || 0.0);
    let words = w.axes_words(&home, [0.0; 2], false);
    let _ = writeln!(w.out, "G28 {words}{f}");
    let tool = prog.first_tool.map_or(m.extrusion.tool, |t| t.tool);
    if let Some(t) = prog.first_tool {
        let _ = writeln!(w.out, "T{}\nM109 S{} T{}", t.tool, t.temperature, t.tool);
    }
    if let Some(on) = tcp_on(post.dialect, tool) {
        let _ = writeln!(w.out, "{on}");
    }
    let mut at = home;
    for s in &prog.steps {
        match s {
            Step::Move(mv) => {
                w.line(&at, mv);
                at = mv.to;
            }
            Step::Travel(t) => {
                for item in t.items(w.m) {
                    match item {
                        TravelItem::Move(mv) => {
                            w.line(&at, &mv);
                            at = mv.to;
                        }
                        TravelItem::ToolChange(tool) => {
                            let _ = writeln!(
                                w.out,
                                "T{}\nM109 S{} T{}",
                                tool.tool, tool.temperature, tool.tool
                            );
                            if post.dialect == Dialect::G43_4 {
                                let _ = writeln!(w.out, "G43.4 H{}", tool.tool);
                            }
                        }
                        TravelItem::ResetE => {
                            w.e = 0.0;
                            if !relative {
                                let _ = writeln!(w.out, "G92 E0");
                            }
                        }
                    }
                }
            }
        }
    }
    match post.dialect {
        Dialect::Joint => {}
        Dialect::G43_4 => {
            let _ = writeln!(w.out, "G49");
        }
        Dialect::Traori => {
            let _ = writeln!(w.out, "TRAFOOF");
        }
    }
    if post.feed == FeedMode::G93 {
        let _ = writeln!(w.out, "G94");
    }
    let _ = writeln!(w.out, "M30");
    w.out
}

pub use super::gcode_read::{
    axes_of, parse_g1, read_program, rotary_motion, GcodeError, GcodeMove,
};
