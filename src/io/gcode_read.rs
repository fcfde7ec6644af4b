//! Reading a 5-axis program back as the motion a controller makes: ours in
//! any dialect of [`crate::kinematics::Post`], or anyone's in the
//! vocabulary real machines use (the data set's reference G-code is the
//! joint dialect; CNC programs bring `G21 G40 G49 G80`, `T1 M6`, `G54`).
//!
//! The reader keeps the controller's state line by line: machine axes,
//! extruder position (`M82`/`M83`, `G92 E`; the extruder's letter from
//! the machine file), feed and feed mode (`G94`/`G93`, lines that set only
//! `F`), the motion mode (`G0`/`G1`, modal: a line of axis words alone
//! moves as the last one did), tool (`T<n>`, with or without `M6`: the
//! support tool's nozzle offset is added back to joint-dialect X/Y), work
//! coordinate system (`G54`–`G59`, offsets from the machine file; `G53`
//! for one line), dwells (`G4 P`/`S`: their time is part of the program's)
//! and tool-centre-point control (`G43.4`/`G49`, `TRAORI`/`TRAFOOF`: X Y
//! Z are then the tip in the part frame, turned into machine axes by
//! inverse kinematics). Rotary axes are read with the machine file's
//! letters and signs. Lengths after `G20` (X Y Z, the extruder, `G94`
//! feeds) are inches, converted to millimetres until `G21`. Codes that
//! change nothing the motion depends on (`G17 G40 G80 G90`, spindle,
//! coolant, temperatures, fans) are taken as they are. Anything it cannot
//! be sure of is an error naming the line: an unknown word or code, a value
//! that is not a finite number, a move before every axis has a position
//! (home with `G28 X… Y… Z… B… C…` or give every axis on the first move).

use super::gcode_words::{line_words, LineWords};
use super::InputError;
use crate::kinematics::{linear_axes, tip_position, Axes, DwellUnit, Machine};
use rayon::prelude::*;
use std::path::Path;

/// A line the reader cannot take.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("line {line}: {msg}")]
pub struct GcodeError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong and what to do.
    pub msg: String,
}

/// One motion line of a program, as a controller executes it (or a
/// dwell: no motion, [`GcodeMove::dwell`] seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GcodeMove {
    /// 1-based line number.
    pub line: usize,
    /// `G1` (true) or `G0`.
    pub linear: bool,
    /// Machine axes before the line: `[X, Y, Z, tilt°, C°]` (the planner's
    /// convention: signs undone, nozzle offset added back).
    pub from: [f64; 5],
    /// Machine axes after it.
    pub to: [f64; 5],
    /// Extruder position after it (absolute, after any `G92`).
    pub e: f64,
    /// Extrusion over the line (mm of filament; negative: retract).
    pub de: f64,
    /// Feed in force: mm/min, or 1/min under `G93`.
    pub f: f64,
    /// `F` is an inverse time (`G93`).
    pub inverse_time: bool,
    /// The controller moves the tip straight in the part frame
    /// (tool-centre-point control on).
    pub tcp: bool,
    /// Active tool number (0 before any `T`).
    pub tool: u32,
    /// Seconds the machine waits on this line (`G4`; 0 for motion).
    pub dwell: f64,
}

impl GcodeMove {
    /// Does the line move any axis?
    pub fn moves_axes(&self) -> bool {
        self.from != self.to
    }

    /// Does the machine extrude while making this move (a `G1` that moves
    /// and advances the filament)?
    pub fn extrudes(&self) -> bool {
        self.linear && self.de > 1e-9 && self.moves_axes()
    }
}

/// The axes of a parsed `[X, Y, Z, tilt°, C°]`.
pub fn axes_of(v: &[f64; 5]) -> Axes {
    Axes {
        xyz: [v[0], v[1], v[2]],
        tilt: v[3].to_radians(),
        c: v[4].to_radians(),
    }
}

/// A program as read: its motion and where its layers begin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// Every line that moves an axis or the extruder, or dwells, in order.
    pub moves: Vec<GcodeMove>,
    /// 1-based lines of the comments that mark a layer change
    /// (`;LAYER:3`, `;LAYER_CHANGE`, `; layer 3`), in order.
    pub layer_marks: Vec<usize>,
}

/// What a code does to the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Code {
    /// `G0` (false) or `G1` (true): a motion, and the motion mode.
    Motion(bool),
    /// `G28`: homing, in machine coordinates.
    Home,
    /// `G92`: the extruder's position set.
    SetPosition,
    /// `G4`: a dwell.
    Dwell,
    /// `G93` (true) or `G94`: the feed mode.
    InverseTime(bool),
    /// `G43.4` / `TRAORI` (true), `G49` / `TRAFOOF`: tool-centre-point
    /// control.
    Tcp(bool),
    /// `G54`…`G59`: the work coordinate system.
    Work(usize),
    /// `G53`: this line's words are machine coordinates.
    MachineCoordinates,
    /// `M83` (true) or `M82`: relative extruder coordinates.
    RelativeE(bool),
    /// `M6`: the tool `T` selects is changed to.
    ToolChange,
    /// `G20` (true: inches) or `G21` (millimetres).
    Inches(bool),
    /// A code that changes nothing the motion depends on.
    Inert,
}

/// The code's meaning, or why it is refused.
fn code(c: &str) -> Result<Code, String> {
    Ok(match c {
        "G0" => Code::Motion(false),
        "G1" => Code::Motion(true),
        "G28" => Code::Home,
        "G92" => Code::SetPosition,
        "G4" => Code::Dwell,
        "G93" => Code::InverseTime(true),
        "G94" => Code::InverseTime(false),
        "G43.4" | "TRAORI" => Code::Tcp(true),
        "G49" | "TRAFOOF" => Code::Tcp(false),
        "G53" => Code::MachineCoordinates,
        "M82" => Code::RelativeE(false),
        "M83" => Code::RelativeE(true),
        "M6" => Code::ToolChange,
        // Plane, millimetres, cutter and canned-cycle cancels, absolute
        // distances, path blending; program stops and ends; spindle (an
        // extruder motor on a converted machine), coolant, motors off;
        // temperatures and fans.
        "G17" | "G40" | "G80" | "G90" | "G61" | "G64" | "M0" | "M1" | "M2" | "M30" | "M3"
        | "M4" | "M5" | "M7" | "M8" | "M9" | "M84" | "M104" | "M109" | "M140" | "M190" | "M106"
        | "M107" => Code::Inert,
        "G20" => Code::Inches(true),
        "G21" => Code::Inches(false),
        c => match c.strip_prefix('G').and_then(|n| n.parse::<usize>().ok()) {
            Some(n @ 54..=59) => Code::Work(n - 54),
            _ => return Err(format!("unsupported code {c}")),
        },
    })
}

/// What [`code`]'s refusal adds: the vocabulary read.
const VOCABULARY: &str = "maamplan reads G0/G1 (G90, absolute), G4 P/S, G17, G20/G21, G28, G40, G43.4/G49, G53, G54-G59, G80, G92 E, G93/G94, TRAORI/TRAFOOF, T<n> and M6, M3/M5, M82/M83, M104/M109, M140/M190, M106/M107, M0-M2, M30 (README, G-code vocabulary)";

/// The motion lines of the program in the file at `path` ([`parse_program`]),
/// every problem an [`InputError`] naming the file: unreadable, a line the
/// reader cannot take, or no motion at all.
pub fn load_program(path: &Path, m: &Machine) -> Result<Program, InputError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        InputError::file(
            path,
            format!("cannot read the program ({e}): check the path"),
        )
    })?;
    let program = parse_program(&text, m).map_err(|e| InputError::at(path, e.line, e.msg))?;
    if !program.moves.iter().any(|mv| mv.moves_axes()) {
        return Err(InputError::file(
            path,
            "no G0/G1 motion found: is this a G-code program?",
        ));
    }
    Ok(program)
}

/// Every motion line of `text` for machine `m` ([`parse_program`]).
pub fn read_program(text: &str, m: &Machine) -> Result<Vec<GcodeMove>, GcodeError> {
    Ok(parse_program(text, m)?.moves)
}

/// The program `text` for machine `m` (dialect letters, signs, work
/// offsets and kinematics from `m`; tool-centre-point control and modes
/// as the program switches them): every line that moves an axis or the
/// extruder, or dwells, and the layer-change comments.
///
/// The lines' words are read on every core, a block of
/// [`WORDS_BLOCK`] lines at a time (each line alone); the controller then
/// follows them in order. The first line in error is the one reported.
pub fn parse_program(text: &str, m: &Machine) -> Result<Program, GcodeError> {
    let mut controller = Controller::new(m);
    let mut out = Program::default();
    let mut lines = text.lines().peekable();
    let mut n = 0;
    while lines.peek().is_some() {
        let block: Vec<&str> = lines.by_ref().take(WORDS_BLOCK).collect();
        let words: Vec<Result<LineWords, String>> =
            block.par_iter().map(|raw| line_words(raw)).collect();
        for (raw, words) in block.into_iter().zip(words) {
            n += 1;
            follow_line(&mut controller, &mut out, n, raw, words)?;
        }
    }
    Ok(out)
}

/// Lines whose words are read at once ([`parse_program`]): enough to
/// share among the cores, few enough that their words take little
/// memory beside the program's.
const WORDS_BLOCK: usize = 16 * 1024;

/// Line `line` (`raw`, its words read) followed by `controller`: its
/// layer mark and the move it makes go to `out`.
fn follow_line(
    controller: &mut Controller<'_>,
    out: &mut Program,
    line: usize,
    raw: &str,
    words: Result<LineWords, String>,
) -> Result<(), GcodeError> {
    let words = words.map_err(|msg| GcodeError { line, msg })?;
    if words.layer_change {
        out.layer_marks.push(line);
    }
    if words.is_empty() {
        return Ok(());
    }
    if let Some(mv) = controller
        .read_line(line, raw, &words)
        .map_err(|msg| GcodeError { line, msg })?
    {
        out.moves.push(mv);
    }
    Ok(())
}

/// A line's words by slot: X Y Z tilt C E F.
type Slots = [Option<f64>; 7];

/// A line's codes, sorted out.
#[derive(Default)]
struct LineCodes {
    /// The one code that takes the line's axis words (motion, homing,
    /// `G92`, dwell), if any.
    consumer: Option<(Code, String)>,
    /// The others, in order.
    modes: Vec<Code>,
    /// Another `M` code than `M6`: a `T` word is its parameter (`M104 S205
    /// T1` heats tool 1), not a tool change.
    other_m: bool,
}

impl LineCodes {
    fn of(words: &LineWords) -> Result<LineCodes, String> {
        let mut out = LineCodes::default();
        for c in &words.codes {
            let k = code(c)?;
            out.other_m |= c.starts_with('M') && k != Code::ToolChange;
            match k {
                Code::Motion(_) | Code::Home | Code::SetPosition | Code::Dwell => {
                    if let Some((_, first)) = &out.consumer {
                        return Err(format!(
                            "{first} and {c} on one line: put each on a line of its own"
                        ));
                    }
                    out.consumer = Some((k, c.clone()));
                }
                k => out.modes.push(k),
            }
        }
        Ok(out)
    }
}

/// The controller's state while it reads a program.
struct Controller<'a> {
    m: &'a Machine,
    /// The tilt axis', C's and the extruder's letters in this machine's
    /// dialect.
    tilt_letter: char,
    c_letter: char,
    e_letter: char,
    /// Machine axes; `None` until known.
    axes: [Option<f64>; 5],
    e: f64,
    f: f64,
    relative_e: bool,
    inverse_time: bool,
    tcp: bool,
    tool: u32,
    /// The motion mode (`G1`: true), once a motion code was given.
    motion: Option<bool>,
    /// The work coordinate system (0: `G54`).
    work: usize,
    /// Millimetres per unit of length the program writes (25.4 after `G20`).
    unit: f64,
}

impl<'a> Controller<'a> {
    fn new(m: &'a Machine) -> Self {
        Controller {
            m,
            tilt_letter: m.post.tilt_letter(m.rotary),
            c_letter: m.post.c_letter(),
            e_letter: m.post.extruder_letter(),
            axes: [None; 5],
            e: 0.0,
            f: 1500.0,
            relative_e: false,
            inverse_time: false,
            tcp: false,
            tool: 0,
            motion: None,
            work: 0,
            unit: 1.0,
        }
    }

    /// Line number `line` (text `raw`, words `words`): the state it
    /// changes, and the motion it makes, if any.
    fn read_line(
        &mut self,
        line: usize,
        raw: &str,
        words: &LineWords,
    ) -> Result<Option<GcodeMove>, String> {
        let codes =
            LineCodes::of(words).map_err(|e| format!("{e} in `{}`: {VOCABULARY}", raw.trim()))?;
        let mut machine_coordinates = false;
        for k in &codes.modes {
            match *k {
                Code::InverseTime(on) => self.inverse_time = on,
                Code::Tcp(on) => self.tcp = on,
                Code::Work(w) => self.work = w,
                Code::MachineCoordinates => machine_coordinates = true,
                Code::RelativeE(on) => self.relative_e = on,
                Code::Inches(on) => self.unit = if on { 25.4 } else { 1.0 },
                _ => {}
            }
        }
        let (vals, params) = self.slots(&words.values, raw)?;
        if let (Some(t), false) = (params.tool, codes.other_m) {
            self.tool = t;
        }
        if let Some(x) = vals[6] {
            if x <= 0.0 {
                return Err(format!("feed F{x} must be positive"));
            }
            self.f = x;
        }
        let moves_words = vals[..6].iter().any(|v| v.is_some());
        let consumer = match &codes.consumer {
            Some((k, c)) => Some((*k, c.as_str())),
            None if moves_words => match self.motion {
                Some(linear) => Some((Code::Motion(linear), if linear { "G1" } else { "G0" })),
                None => {
                    return Err(format!(
                        "axis words without G0 or G1 in `{}`: give the motion code",
                        raw.trim()
                    ))
                }
            },
            None => None,
        };
        match consumer {
            Some((Code::Home, _)) => self.home(&vals),
            Some((Code::SetPosition, _)) => self.set_position(&vals)?,
            Some((Code::Dwell, _)) => return self.dwell(line, &vals, &params, raw).map(Some),
            Some((Code::Motion(linear), c)) => {
                self.motion = Some(linear);
                let offset = if machine_coordinates {
                    [0.0; 3]
                } else {
                    self.m.post.work_offset(self.work)
                };
                return self.motion(line, c, linear, &vals, offset);
            }
            _ => {}
        }
        Ok(None)
    }

    /// The words of a line (text `raw`) in their slots, and its parameters.
    fn slots(&self, words: &[(char, f64)], raw: &str) -> Result<(Slots, Params), String> {
        let (tl, cl, el) = (self.tilt_letter, self.c_letter, self.e_letter);
        let mut vals: Slots = [None; 7];
        let mut params = Params::default();
        for &(k, x) in words {
            let slot = match k {
                'X' => 0,
                'Y' => 1,
                'Z' => 2,
                c if c == tl => 3,
                c if c == cl => 4,
                c if c == el => 5,
                'F' => 6,
                'P' => {
                    params.p = Some(x);
                    continue;
                }
                'S' => {
                    params.s = Some(x);
                    continue;
                }
                'T' => {
                    params.tool = (x >= 0.0 && x.fract() == 0.0 && x < 1e9).then_some(x as u32);
                    if params.tool.is_none() {
                        return Err(format!("T{x} in `{}` is not a tool number", raw.trim()));
                    }
                    continue;
                }
                'H' | 'D' | 'R' => continue,
                c => {
                    return Err(format!(
                        "unknown word '{c}' in `{}`: this machine's axes are X Y Z {tl} {cl} and its extruder {el} (set post.tilt_letter / post.c_letter / post.extruder_letter in the machine file)",
                        raw.trim()
                    ))
                }
            };
            // Lengths in the program's unit; an inverse-time F is none.
            let length = matches!(slot, 0..=2 | 5) || (slot == 6 && !self.inverse_time);
            vals[slot] = Some(if length { x * self.unit } else { x });
        }
        Ok((vals, params))
    }

    /// `G28`: homing sets the axes it names, in machine coordinates in
    /// every mode.
    fn home(&mut self, vals: &Slots) {
        let post = &self.m.post;
        let signs = [1.0, 1.0, 1.0, post.tilt_sign, post.c_sign];
        for ((axis, v), sign) in self.axes.iter_mut().zip(&vals[..5]).zip(signs) {
            if let Some(x) = v {
                *axis = Some(x * sign);
            }
        }
    }

    /// `G92`: only the extruder's position may be set.
    fn set_position(&mut self, vals: &Slots) -> Result<(), String> {
        if vals[..5].iter().any(|v| v.is_some()) {
            return Err(format!(
                "G92 on a motion axis shifts the coordinates, which the simulator does not follow: use G92 {} only",
                self.e_letter
            ));
        }
        if let Some(x) = vals[5] {
            self.e = x;
        }
        Ok(())
    }

    /// `G4` on line `line`: a wait of `P` (the machine file's unit) or `S`
    /// seconds, where the machine stands.
    fn dwell(
        &self,
        line: usize,
        vals: &Slots,
        params: &Params,
        raw: &str,
    ) -> Result<GcodeMove, String> {
        let seconds = match (params.p, params.s) {
            _ if vals[..6].iter().any(|v| v.is_some()) => None,
            (Some(p), None) => Some(match self.m.post.dwell_unit() {
                DwellUnit::Milliseconds => p / 1000.0,
                DwellUnit::Seconds => p,
            }),
            (None, Some(s)) => Some(s),
            _ => None,
        };
        let Some(seconds) = seconds.filter(|s| *s >= 0.0) else {
            return Err(format!(
                "`{}`: a dwell takes its time as G4 P (in post.dwell_p units, ms by default) or G4 S (seconds), ≥ 0",
                raw.trim()
            ));
        };
        let at = known(&self.axes).unwrap_or([0.0; 5]);
        Ok(GcodeMove {
            line,
            linear: false,
            from: at,
            to: at,
            e: self.e,
            de: 0.0,
            f: self.f,
            inverse_time: self.inverse_time,
            tcp: self.tcp,
            tool: self.tool,
            dwell: seconds,
        })
    }

    /// `G0`/`G1` (`code`, `linear`) on line `line`, X Y Z words in the
    /// work coordinate system whose origin is `offset`: the motion, unless
    /// the line changes nothing.
    fn motion(
        &mut self,
        line: usize,
        code: &str,
        linear: bool,
        vals: &Slots,
        offset: [f64; 3],
    ) -> Result<Option<GcodeMove>, String> {
        let moves_axis = vals[..5].iter().any(|v| v.is_some());
        let de = match vals[5] {
            Some(x) if self.relative_e => x,
            Some(x) => x - self.e,
            None => 0.0,
        };
        let from = known(&self.axes);
        if from.is_none() && moves_axis {
            self.check_start(code, vals)?;
        }
        // Every axis given on the first move: the machine starts there.
        let to = if moves_axis {
            Some(self.target(vals, from, offset))
        } else {
            from
        };
        if let Some(to) = to {
            self.axes = to.map(Some);
        }
        self.e += de;
        // A line that changes nothing is no motion for a controller.
        Ok(match (from, to) {
            (Some(from), Some(to)) if to != from || de != 0.0 => Some(GcodeMove {
                line,
                linear,
                from,
                to,
                e: self.e,
                de,
                f: self.f,
                inverse_time: self.inverse_time,
                tcp: self.tcp,
                tool: self.tool,
                dwell: 0.0,
            }),
            _ => None,
        })
    }

    /// A first move must give every axis that is still unknown.
    fn check_start(&self, code: &str, vals: &Slots) -> Result<(), String> {
        let missing: Vec<String> = ['X', 'Y', 'Z', self.tilt_letter, self.c_letter]
            .into_iter()
            .zip(self.axes.iter().zip(&vals[..5]))
            .filter(|(_, (a, v))| a.is_none() && v.is_none())
            .map(|(c, _)| c.to_string())
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(format!(
            "{code} before every axis has a position ({} unknown): home with G28 naming every axis, or give every axis on the first move",
            missing.join(", ")
        ))
    }

    /// The machine axes after a motion line with words `vals`, from
    /// `from` (`None`: every axis is given), X Y Z words relative to
    /// `offset`.
    fn target(&self, vals: &Slots, from: Option<[f64; 5]>, offset: [f64; 3]) -> [f64; 5] {
        let m = self.m;
        let post = &m.post;
        let from = from.unwrap_or([0.0; 5]);
        let tilt = vals[3].map_or(from[3], |x| x * post.tilt_sign);
        let c = vals[4].map_or(from[4], |x| x * post.c_sign);
        let (tr, cr) = (tilt.to_radians(), c.to_radians());
        if self.tcp {
            // The words are the tip in the part frame.
            let cur = tip_position(
                m,
                [from[0], from[1], from[2]],
                from[3].to_radians(),
                from[4].to_radians(),
            );
            let p = std::array::from_fn(|k| vals[k].map_or(cur[k], |x| x + offset[k]));
            let xyz = linear_axes(m, p, tr, cr);
            return [xyz[0], xyz[1], xyz[2], tilt, c];
        }
        let nozzle = if self.tool == m.support.tool && self.tool != m.extrusion.tool {
            m.support.offset
        } else {
            [0.0; 2]
        };
        let x = vals[0].map_or(from[0], |x| x + offset[0] + nozzle[0]);
        let y = vals[1].map_or(from[1], |y| y + offset[1] + nozzle[1]);
        let z = vals[2].map_or(from[2], |z| z + offset[2]);
        [x, y, z, tilt, c]
    }
}

/// A line's words that are no axis: `P` and `S` (a dwell's time, a
/// temperature, a speed) and `T` (a tool).
#[derive(Clone, Copy, Debug, Default)]
struct Params {
    p: Option<f64>,
    s: Option<f64>,
    tool: Option<u32>,
}

fn known(axes: &[Option<f64>; 5]) -> Option<[f64; 5]> {
    let mut v = [0.0; 5];
    for k in 0..5 {
        v[k] = axes[k]?;
    }
    Some(v)
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

/// Eq. 7 on a program's moves: total and largest single-step |Δtilt| + |ΔC|
/// (degrees) over the `G1` moves that do not retract (printing moves and
/// approaches; `G0` travels excluded).
pub fn rotary_motion(moves: &[GcodeMove]) -> (f64, f64) {
    let mut total = 0.0;
    let mut max_step: f64 = 0.0;
    for mv in moves {
        if mv.linear && mv.de >= 0.0 {
            let s = (mv.to[3] - mv.from[3]).abs() + (mv.to[4] - mv.from[4]).abs();
            total += s;
            max_step = max_step.max(s);
        }
    }
    (total, max_step)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A program `n` lines long: the axes set, then one printing move a
    /// line, a layer comment every 10,000 lines.
    fn long_program(n: usize) -> Vec<String> {
        let mut lines = vec!["G90".to_string(), "G28 X0 Y0 Z50 B0 C0".to_string()];
        while lines.len() < n {
            let k = lines.len() + 1;
            lines.push(if k % 10_000 == 0 {
                format!(";LAYER:{k}")
            } else {
                format!("G1 X{} Y0 Z1 E{} F1500", k % 100, k)
            });
        }
        lines
    }

    /// Lines read a block at a time on every core keep their numbers
    /// across the blocks: the layer marks and the moves are those of the
    /// lines read one by one, and an error deep in a later block names
    /// its own line, not another block's.
    #[test]
    fn programs_longer_than_a_block_keep_their_line_numbers() {
        let m = Machine::default();
        let lines = long_program(3 * WORDS_BLOCK + 1_234);
        let p = parse_program(&lines.join("\n"), &m).unwrap();
        let marks: Vec<usize> = (1..=lines.len()).filter(|k| k % 10_000 == 0).collect();
        assert_eq!(p.layer_marks, marks);
        // Every G1 line moves (homing only sets the axes).
        assert_eq!(p.moves.len(), lines.len() - 2 - marks.len());
        let last = p.moves.last().unwrap();
        assert_eq!(last.to[0], ((lines.len()) % 100) as f64);
        for bad in [WORDS_BLOCK, WORDS_BLOCK + 1, 2 * WORDS_BLOCK + 777] {
            let mut broken = lines.clone();
            broken[bad - 1] = "G1 X1 Q5".into();
            let err = parse_program(&broken.join("\n"), &m).unwrap_err();
            assert_eq!(err.line, bad, "{}", err.msg);
        }
    }
}
