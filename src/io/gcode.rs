//! G-code in the joint-space dialect of the data set's reference output
//! (`reference_gcode/simple_curve_Gcode.txt`): absolute positions, `G1 X Y
//! Z B C E` while printing (A for the tilt on A/C machines), E absolute and
//! reset per layer with `G92 E0`, travels as `G0`, tool changes as `T<n>`
//! followed by `M109`. A comment header names maamplan's version, the
//! machine, the source and the command. Every value is written with three
//! decimals — the values the planner checked ([`crate::kinematics::DECIMALS`]).
//!
//! [`parse_moves`] reads any program in this dialect back (ours or the
//! reference's) as the motion a controller would make.

use crate::kinematics::{Axes, Machine, Rotary};
use crate::plan::program::{Move, MoveKind, Program, Step, TravelItem};
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
    let s = format!("{:.3}", x + 0.0);
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

struct Writer<'a> {
    m: &'a Machine,
    out: String,
    tilt: char,
    feed: Option<String>,
}

impl Writer<'_> {
    fn axes_words(&self, a: &Axes, offset: [f64; 2]) -> String {
        format!(
            "X{} Y{} Z{} {}{} C{}",
            f3(a.xyz[0] - offset[0]),
            f3(a.xyz[1] - offset[1]),
            f3(a.xyz[2]),
            self.tilt,
            f3(a.tilt.to_degrees()),
            f3(a.c.to_degrees())
        )
    }

    /// ` F…` when the feed changes.
    fn feed_word(&mut self, mm_s: f64) -> String {
        let f = feed(mm_s);
        if self.feed.as_deref() == Some(f.as_str()) {
            String::new()
        } else {
            self.feed = Some(f.clone());
            format!(" F{f}")
        }
    }

    fn line(&mut self, from: &Axes, mv: &Move) {
        let moves_axes = !matches!(mv.kind, MoveKind::Retract | MoveKind::Prime);
        if moves_axes && mv.to == *from && mv.kind != MoveKind::Print {
            return; // Already there (e.g. no lift needed at the start).
        }
        let words = self.axes_words(&mv.to, mv.offset);
        let f = self.feed_word(mv.feed);
        let _ = match mv.kind {
            MoveKind::Print => writeln!(self.out, "G1 {words} E{}{f}", f3(mv.e)),
            MoveKind::Retract | MoveKind::Prime => writeln!(self.out, "G1 E{}{f}", f3(mv.e)),
            MoveKind::Lift | MoveKind::Lower
                if mv.to.xyz[0] == from.xyz[0]
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
}

/// The whole program for machine `m`.
pub fn write_gcode(m: &Machine, prog: &Program, header: &GcodeHeader) -> String {
    let tilt = if m.rotary == Rotary::AC { 'A' } else { 'B' };
    let mut w = Writer {
        m,
        out: String::with_capacity(prog.steps.len() * 56 + 1024),
        tilt,
        feed: None,
    };
    let _ = writeln!(
        w.out,
        "; maamplan {} — joint-space G-code: G1 X Y Z {tilt} C E (mm, degrees), absolute E reset per layer",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        w.out,
        "; machine: configuration {:?} {:?}, print feed {} mm/s, tip speed {:?} mm/s, margin {} mm, tip tolerance {} mm",
        m.configuration, m.rotary, m.feed, m.tip_speed, m.margin, m.tip_tolerance
    );
    let _ = writeln!(
        w.out,
        "; tools: T{} main {} °C, T{} support {} °C ({:.1} mm/s, ×{} extrusion)",
        m.extrusion.tool,
        m.extrusion.temperature,
        m.support.tool,
        m.support.temperature,
        m.support.feed,
        m.support.extrusion
    );
    if !header.source.is_empty() {
        let _ = writeln!(w.out, "; source: {}", header.source);
    }
    if !header.command.is_empty() {
        let _ = writeln!(w.out, "; command: {}", header.command);
    }
    let home = prog.home;
    let _ = writeln!(w.out, "G90\nM82");
    if let Some(t) = prog.first_tool {
        let _ = writeln!(w.out, "M104 S{} T{}", t.temperature, t.tool);
    }
    let f = w.feed_word(m.travel.speed);
    let words = w.axes_words(&home, [0.0; 2]);
    let _ = writeln!(w.out, "G28 {words}{f}");
    if let Some(t) = prog.first_tool {
        let _ = writeln!(w.out, "T{}\nM109 S{} T{}", t.tool, t.temperature, t.tool);
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
                        }
                        TravelItem::ResetE => {
                            let _ = writeln!(w.out, "G92 E0");
                        }
                    }
                }
            }
        }
    }
    let _ = writeln!(w.out, "M30");
    w.out
}

/// One motion line of a program, as a controller executes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GcodeMove {
    /// 1-based line number.
    pub line: usize,
    /// `G1` (true) or `G0`.
    pub linear: bool,
    /// Axes before the line: `[X, Y, Z, tilt°, C°]`.
    pub from: [f64; 5],
    /// Axes after it.
    pub to: [f64; 5],
    /// Extruder position after it (absolute, after any `G92`).
    pub e: f64,
    /// Extrusion over the line (mm of filament; negative: retract).
    pub de: f64,
    /// Feed in force (mm/min).
    pub f: f64,
}

/// Every `G0`/`G1` line of `text` with its start and end axes, E and feed
/// (absolute or relative E per `M82`/`M83`, `G92 E` resets, `G28` homes to
/// the axes it names). Lines with no axis or E change are left out.
pub fn parse_moves(text: &str) -> Vec<GcodeMove> {
    let mut st = [0.0f64; 5];
    let (mut e, mut f, mut rel_e) = (0.0f64, 1500.0f64, false);
    let mut out = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split(';').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let Some(cmd) = words.next() else {
            continue;
        };
        let mut vals: [Option<f64>; 7] = [None; 7]; // X Y Z tilt C E F
        for wd in words {
            let (k, num) = wd.split_at(wd.char_indices().nth(1).map_or(wd.len(), |c| c.0));
            let Ok(x) = num.parse::<f64>() else {
                continue;
            };
            let slot = match k.to_ascii_uppercase().as_str() {
                "X" => 0,
                "Y" => 1,
                "Z" => 2,
                "A" | "B" => 3,
                "C" => 4,
                "E" => 5,
                "F" => 6,
                _ => continue,
            };
            vals[slot] = Some(x);
        }
        match cmd.to_ascii_uppercase().as_str() {
            "M82" => rel_e = false,
            "M83" => rel_e = true,
            "G92" => {
                if let Some(x) = vals[5] {
                    e = x;
                }
            }
            "G28" => {
                for k in 0..5 {
                    if let Some(x) = vals[k] {
                        st[k] = x;
                    }
                }
            }
            c @ ("G0" | "G1" | "G00" | "G01") => {
                if let Some(x) = vals[6] {
                    f = x;
                }
                let from = st;
                for k in 0..5 {
                    if let Some(x) = vals[k] {
                        st[k] = x;
                    }
                }
                let de = match vals[5] {
                    Some(x) if rel_e => x,
                    Some(x) => x - e,
                    None => 0.0,
                };
                e += de;
                if from != st || de != 0.0 {
                    out.push(GcodeMove {
                        line: n + 1,
                        linear: c.ends_with('1'),
                        from,
                        to: st,
                        e,
                        de,
                        f,
                    });
                }
            }
            _ => {}
        }
    }
    out
}

/// The axes of a parsed `[X, Y, Z, tilt°, C°]`.
pub fn axes_of(v: &[f64; 5]) -> Axes {
    Axes {
        xyz: [v[0], v[1], v[2]],
        tilt: v[3].to_radians(),
        c: v[4].to_radians(),
    }
}

/// The machine axes of every `G1 X` line: `[X, Y, Z, tilt°, C°, E]`.
pub fn parse_g1(text: &str) -> Vec<[f64; 6]> {
    text.lines()
        .filter(|l| l.starts_with("G1 X"))
        .map(|l| {
            let mut v = [0.0; 6];
            for f in l.split_whitespace().skip(1) {
                let (k, num) = f.split_at(1);
                let x: f64 = num.parse().unwrap_or(f64::NAN);
                match k {
                    "X" => v[0] = x,
                    "Y" => v[1] = x,
                    "Z" => v[2] = x,
                    "B" | "A" => v[3] = x,
                    "C" => v[4] = x,
                    "E" => v[5] = x,
                    _ => {}
                }
            }
            v
        })
        .collect()
}

/// Eq. 7 on a G-code program: total and largest single-step |Δtilt| + |ΔC|
/// (degrees) over the `G1` moves that do not retract (printing moves and
/// approaches; `G0` travels excluded).
pub fn rotary_motion(text: &str) -> (f64, f64) {
    let mut total = 0.0;
    let mut max_step: f64 = 0.0;
    for mv in parse_moves(text) {
        if mv.linear && mv.de >= 0.0 {
            let s = (mv.to[3] - mv.from[3]).abs() + (mv.to[4] - mv.from[4]).abs();
            total += s;
            max_step = max_step.max(s);
        }
    }
    (total, max_step)
}
