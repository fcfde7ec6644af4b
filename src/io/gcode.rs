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

/// Append `x` with three decimals, never `-0.000`.
fn push_f3(out: &mut String, x: f64) {
    let at = out.len();
    super::fixed::push_fixed(out, x + 0.0, 3);
    if &out[at..] == "-0.000" {
        out.replace_range(at..at + 1, "");
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
    /// The extruder's letter.
    e_letter: char,
    /// `G54`'s origin in the machine's frame: written X Y Z are relative
    /// to it.
    work: [f64; 3],
    feed: Option<String>,
    /// The mm/s whose text `feed` is: the same speed needs no new text.
    feed_of: Option<f64>,
    /// Extruder position as the program last left it.
    e: f64,
    /// The current line's feed word, kept between lines so that it is
    /// not allocated for each.
    f_word: String,
}

impl Writer<'_> {
    fn tcp(&self) -> bool {
        self.post.interpolation() == Interpolation::TipLinear
    }

    /// Append the position words of `a`: machine X Y Z (shifted by minus
    /// the nozzle offset), or the part-frame tip when `tip` (tool-centre-point
    /// control on); then the rotary axes. Every word goes straight into
    /// `out`: a program has hundreds of thousands of lines, and a string per
    /// word would cost more than formatting the numbers.
    fn push_axes(&mut self, a: &Axes, offset: [f64; 2], tip: bool) {
        let mut xyz = if tip {
            self.m.tip(a)
        } else {
            [a.xyz[0] - offset[0], a.xyz[1] - offset[1], a.xyz[2]]
        };
        for (v, o) in xyz.iter_mut().zip(self.work) {
            *v -= o;
        }
        let out = &mut self.out;
        for (letter, v) in ['X', 'Y', 'Z'].into_iter().zip(xyz) {
            if letter != 'X' {
                out.push(' ');
            }
            out.push(letter);
            push_f3(out, v);
        }
        out.push(' ');
        out.push(self.tilt);
        push_f3(out, self.post.tilt_sign * a.tilt.to_degrees());
        out.push(' ');
        out.push(self.c);
        push_f3(out, self.post.c_sign * a.c.to_degrees());
    }

    /// Sets `f_word` to ` F…` when the feed changes (G94), or to every `G1`
    /// line's inverse time (G93: `seconds` of the line; rapids take none);
    /// empty otherwise.
    fn feed_word(&mut self, mm_s: f64, rapid: bool, seconds: impl FnOnce() -> f64) {
        self.f_word.clear();
        if self.post.feed == FeedMode::G93 {
            if !rapid {
                self.f_word.push_str(" F");
                self.f_word.push_str(&inverse_time(seconds()));
            }
            return;
        }
        if self.feed_of == Some(mm_s) {
            return;
        }
        self.feed_of = Some(mm_s);
        let f = feed(mm_s);
        if self.feed.as_deref() != Some(f.as_str()) {
            self.f_word.push_str(" F");
            self.f_word.push_str(&f);
            self.feed = Some(f);
        }
    }

    /// Append `E…` for a line that leaves the extruder at `e`.
    fn push_e(&mut self, e: f64) {
        let w = match self.post.extrusion {
            ExtrusionMode::Absolute => e,
            ExtrusionMode::Relative => e - self.e,
        };
        self.e = e;
        self.out.push(self.e_letter);
        push_f3(&mut self.out, w);
    }

    /// Append the line of `mv` (from `from`), with its feed word.
    fn line(&mut self, from: &Axes, mv: &Move) {
        let moves_axes = !matches!(mv.kind, MoveKind::Retract | MoveKind::Prime);
        if moves_axes && mv.to == *from && mv.kind != MoveKind::Print {
            return; // Already there (e.g. no lift needed at the start).
        }
        let rapid = matches!(mv.kind, MoveKind::Lift | MoveKind::Lower | MoveKind::Travel);
        let (m, e) = (self.m, self.e);
        self.feed_word(mv.feed, rapid, || {
            move_seconds(m, from, &mv.to, mv.feed, mv.e - e)
        });
        let tcp = self.tcp();
        match mv.kind {
            MoveKind::Print => {
                self.out.push_str("G1 ");
                self.push_axes(&mv.to, mv.offset, tcp);
                self.out.push(' ');
                self.push_e(mv.e);
            }
            MoveKind::Retract | MoveKind::Prime => {
                self.out.push_str("G1 ");
                self.push_e(mv.e);
            }
            MoveKind::Lift | MoveKind::Lower
                if !tcp
                    && mv.to.xyz[0] == from.xyz[0]
                    && mv.to.xyz[1] == from.xyz[1]
                    && mv.to.tilt == from.tilt
                    && mv.to.c == from.c =>
            {
                self.out.push_str("G0 Z");
                push_f3(&mut self.out, mv.to.xyz[2] - self.work[2]);
            }
            MoveKind::Lift | MoveKind::Lower | MoveKind::Travel => {
                self.out.push_str("G0 ");
                self.push_axes(&mv.to, mv.offset, tcp);
            }
            MoveKind::Approach => {
                self.out.push_str("G1 ");
                self.push_axes(&mv.to, mv.offset, tcp);
            }
        }
        self.end_line();
    }

    /// End the line with its feed word ([`Writer::feed_word`]).
    fn end_line(&mut self) {
        self.out.push_str(&self.f_word);
        self.out.push('\n');
    }

    fn header(&mut self, header: &GcodeHeader) {
        let (m, post, t, c, e) = (self.m, self.post, self.tilt, self.c, self.e_letter);
        let what = match post.dialect {
            Dialect::Joint => format!("joint-space G-code: G1 X Y Z {t} {c} {e} (machine axes, mm, degrees)"),
            Dialect::G43_4 => format!("tool-centre-point G-code (G43.4): G1 X Y Z {t} {c} {e} (tip in the part frame, mm, degrees)"),
            Dialect::Traori => format!("tool-centre-point G-code (TRAORI): G1 X Y Z {t} {c} {e} (tip in the part frame, mm, degrees)"),
        };
        let e = match post.extrusion {
            ExtrusionMode::Absolute => format!("absolute {e} reset per layer"),
            ExtrusionMode::Relative => format!("relative {e}"),
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
        e_letter: post.extruder_letter(),
        work: post.work_offset(0),
        feed: None,
        feed_of: None,
        e: 0.0,
        f_word: String::new(),
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
    w.feed_word(m.travel.speed, true, || 0.0);
    w.out.push_str("G28 ");
    // Homing names machine coordinates, whatever the work offset.
    let work = std::mem::take(&mut w.work);
    w.push_axes(&home, [0.0; 2], false);
    w.work = work;
    w.end_line();
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
                                let _ = writeln!(w.out, "G92 {}0", w.e_letter);
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
    axes_of, load_program, parse_g1, read_program, rotary_motion, GcodeError, GcodeMove,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_written_with_three_decimals_and_never_minus_zero() {
        let mut s = String::new();
        for x in [-0.0004, -0.0, 0.0, 0.0004, -0.0005, 1.2345, -12.5, 230.0] {
            push_f3(&mut s, x);
            s.push(' ');
        }
        assert_eq!(s, "0.000 0.000 0.000 0.000 -0.001 1.234 -12.500 230.000 ");
    }
}
