//! Reading a 5-axis program back as the motion a controller makes: ours in
//! any dialect of [`crate::kinematics::Post`], or anyone's in the same
//! vocabulary (the data set's reference G-code is the joint dialect).
//!
//! The reader keeps the controller's state line by line: machine axes,
//! extruder position (`M82`/`M83`, `G92 E`), feed and feed mode
//! (`G94`/`G93`), tool (`T<n>`: the support tool's nozzle offset is added
//! back to joint-dialect X/Y), and tool-centre-point control (`G43.4`/`G49`,
//! `TRAORI`/`TRAFOOF`: X Y Z are then the tip in the part frame, turned
//! into machine axes by inverse kinematics). Rotary axes are read with the
//! machine file's letters and signs. Anything it cannot be sure of is an
//! error naming the line: an unknown word or code, a value that is not a
//! finite number, a move before every axis has a position (home with
//! `G28 X… Y… Z… B… C…` or give every axis on the first move).

use super::InputError;
use crate::kinematics::{linear_axes, tip_position, Axes, Machine};
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

/// One motion line of a program, as a controller executes it.
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

/// `T<n>`: the tool it selects.
fn tool_change(code: &str) -> Option<u32> {
    code.strip_prefix('T')?.parse().ok()
}

/// Codes whose effect the reader follows.
fn followed(code: &str) -> bool {
    matches!(
        code,
        "M82"
            | "M83"
            | "G93"
            | "G94"
            | "G43.4"
            | "TRAORI"
            | "G49"
            | "TRAFOOF"
            | "G92"
            | "G28"
            | "G0"
            | "G1"
            | "G00"
            | "G01"
    ) || tool_change(code).is_some()
}

/// Codes that do not move the machine and are taken as they are.
fn harmless(code: &str) -> bool {
    matches!(
        code,
        "G4" | "G04" | "G17" | "G21" | "G90" | "G40" | "G80" | "G53" | "G54" | "G64" | "G61"
    ) || code.starts_with('M')
}

/// The motion lines of the program in the file at `path` ([`read_program`]),
/// every problem an [`InputError`] naming the file: unreadable, a line the
/// reader cannot take, or no motion at all.
pub fn load_program(path: &Path, m: &Machine) -> Result<Vec<GcodeMove>, InputError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        InputError::file(
            path,
            format!("cannot read the program ({e}): check the path"),
        )
    })?;
    let moves = read_program(&text, m).map_err(|e| InputError::at(path, e.line, e.msg))?;
    if moves.is_empty() {
        return Err(InputError::file(
            path,
            "no G0/G1 motion found: is this a G-code program?",
        ));
    }
    Ok(moves)
}

/// Every motion line of `text` for machine `m` (dialect letters, signs and
/// kinematics from `m`; tool-centre-point control and modes as the program
/// switches them). Lines that neither move an axis nor the extruder are
/// left out.
pub fn read_program(text: &str, m: &Machine) -> Result<Vec<GcodeMove>, GcodeError> {
    let mut controller = Controller::new(m);
    let mut out = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        if let Some(mv) = controller
            .read_line(line, raw)
            .map_err(|msg| GcodeError { line, msg })?
        {
            out.push(mv);
        }
    }
    Ok(out)
}

/// A line's words by slot: X Y Z tilt C E F.
type Slots = [Option<f64>; 7];

/// The controller's state while it reads a program.
struct Controller<'a> {
    m: &'a Machine,
    /// The tilt axis' and C's letters in this machine's dialect.
    tilt_letter: char,
    c_letter: char,
    /// Machine axes; `None` until known.
    axes: [Option<f64>; 5],
    e: f64,
    f: f64,
    relative_e: bool,
    inverse_time: bool,
    tcp: bool,
    tool: u32,
}

impl<'a> Controller<'a> {
    fn new(m: &'a Machine) -> Self {
        Controller {
            m,
            tilt_letter: m.post.tilt_letter(m.rotary),
            c_letter: m.post.c_letter(),
            axes: [None; 5],
            e: 0.0,
            f: 1500.0,
            relative_e: false,
            inverse_time: false,
            tcp: false,
            tool: 0,
        }
    }

    /// Line number `line` (text `raw`): the state it changes, and the
    /// motion it makes, if any.
    fn read_line(&mut self, line: usize, raw: &str) -> Result<Option<GcodeMove>, String> {
        let Some((code, words)) = tokens(raw)? else {
            return Ok(None);
        };
        if !(followed(&code) || harmless(&code)) {
            return Err(format!(
                "unsupported code {code} in `{}`: the simulator follows G0/G1 moves (G90, absolute), G28, G92 E, G93/G94, G43.4/G49, TRAORI/TRAFOOF, M82/M83 and T<n>",
                raw.trim()
            ));
        }
        let vals = self.slots(&words, raw)?;
        match code.as_str() {
            "M82" => self.relative_e = false,
            "M83" => self.relative_e = true,
            "G93" => self.inverse_time = true,
            "G94" => self.inverse_time = false,
            "G43.4" | "TRAORI" => self.tcp = true,
            "G49" | "TRAFOOF" => self.tcp = false,
            "G92" => {
                if vals[..5].iter().any(|v| v.is_some()) {
                    return Err(
                        "G92 on a motion axis shifts the coordinates, which the simulator does not follow: use G92 E only".into(),
                    );
                }
                if let Some(x) = vals[5] {
                    self.e = x;
                }
            }
            "G28" => self.home(&vals),
            "G0" | "G1" | "G00" | "G01" => return self.motion(line, &code, &vals),
            // The rest was checked above: tool changes, and codes that do
            // not move the machine.
            c => {
                if let Some(t) = tool_change(c) {
                    self.tool = t;
                }
            }
        }
        Ok(None)
    }

    /// The words of a line (text `raw`) in their slots.
    fn slots(&self, words: &[(char, f64)], raw: &str) -> Result<Slots, String> {
        let (tl, cl) = (self.tilt_letter, self.c_letter);
        let mut vals: Slots = [None; 7];
        for &(k, x) in words {
            let slot = match k {
                'X' => 0,
                'Y' => 1,
                'Z' => 2,
                c if c == tl => 3,
                c if c == cl => 4,
                'E' => 5,
                'F' => 6,
                'S' | 'P' | 'H' | 'T' | 'D' => continue,
                c => {
                    return Err(format!(
                        "unknown word '{c}' in `{}`: this machine's axes are X Y Z {tl} {cl} (set post.tilt_letter / post.c_letter in the machine file)",
                        raw.trim()
                    ))
                }
            };
            vals[slot] = Some(x);
        }
        Ok(vals)
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

    /// `G0`/`G1` (`code`) on line `line`: the motion, unless the line
    /// changes nothing.
    fn motion(
        &mut self,
        line: usize,
        code: &str,
        vals: &Slots,
    ) -> Result<Option<GcodeMove>, String> {
        if let Some(x) = vals[6] {
            if x <= 0.0 {
                return Err(format!("feed F{x} must be positive"));
            }
            self.f = x;
        }
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
            Some(self.target(vals, from))
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
                linear: code.ends_with('1'),
                from,
                to,
                e: self.e,
                de,
                f: self.f,
                inverse_time: self.inverse_time,
                tcp: self.tcp,
                tool: self.tool,
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
    /// `from` (`None`: every axis is given).
    fn target(&self, vals: &Slots, from: Option<[f64; 5]>) -> [f64; 5] {
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
            let p = std::array::from_fn(|k| vals[k].unwrap_or(cur[k]));
            let xyz = linear_axes(m, p, tr, cr);
            return [xyz[0], xyz[1], xyz[2], tilt, c];
        }
        let off = if self.tool == m.support.tool && self.tool != m.extrusion.tool {
            m.support.offset
        } else {
            [0.0; 2]
        };
        let x = vals[0].map_or(from[0], |x| x + off[0]);
        let y = vals[1].map_or(from[1], |y| y + off[1]);
        let z = vals[2].unwrap_or(from[2]);
        [x, y, z, tilt, c]
    }
}

fn known(axes: &[Option<f64>; 5]) -> Option<[f64; 5]> {
    let mut v = [0.0; 5];
    for k in 0..5 {
        v[k] = axes[k]?;
    }
    Some(v)
}

/// The words of one line, upper-cased: the code (`G1`, `M104`, `T2`,
/// `TRAORI`) and its `(letter, value)` pairs. Comments (`;…`, `(…)`) and a
/// leading `N` line number are dropped.
type Words = (String, Vec<(char, f64)>);

/// A whitespace-separated token as words: `X1.5`, or run together as many
/// controllers accept them (`G1X1.5Y2`). `None` when a piece is not a
/// letter followed by a number.
fn split_words(token: &str) -> Option<Vec<(char, &str)>> {
    let starts: Vec<usize> = token
        .char_indices()
        .filter(|(_, c)| c.is_ascii_alphabetic())
        .map(|(i, _)| i)
        .collect();
    if starts.first() != Some(&0) {
        return None;
    }
    let mut out = Vec::with_capacity(starts.len());
    for (k, &i) in starts.iter().enumerate() {
        let end = starts.get(k + 1).copied().unwrap_or(token.len());
        let num = &token[i + 1..end];
        if num.is_empty() {
            return None;
        }
        out.push((token.as_bytes()[i].to_ascii_uppercase() as char, num));
    }
    Some(out)
}

/// The words of one line, upper-cased: the code (`G1`, `M104`, `T2`,
/// `TRAORI`) and its `(letter, value)` pairs. Comments (`;…`, `(…)`) and a
/// leading `N` line number are dropped.
fn tokens(raw: &str) -> Result<Option<Words>, String> {
    let mut s = String::with_capacity(raw.len());
    let mut depth = 0;
    for ch in raw.chars() {
        match ch {
            ';' if depth == 0 => break,
            '(' => depth += 1,
            ')' if depth > 0 => depth -= 1,
            _ if depth == 0 => s.push(ch),
            _ => {}
        }
    }
    let trimmed = s.trim().to_ascii_uppercase();
    if trimmed == "TRAORI" || trimmed == "TRAFOOF" {
        return Ok(Some((trimmed, Vec::new())));
    }
    let mut pieces = Vec::new();
    for token in s.split_whitespace() {
        let words = split_words(token)
            .ok_or_else(|| format!("'{token}' is not a letter and a finite number"))?;
        pieces.extend(words.into_iter().map(|w| (w, token)));
    }
    if pieces.first().is_some_and(|((k, _), _)| *k == 'N') {
        pieces.remove(0);
    }
    let mut pieces = pieces.into_iter();
    let Some(((k, num), _)) = pieces.next() else {
        return Ok(None);
    };
    let code = format!("{k}{}", num.to_ascii_uppercase());
    let mut words = Vec::new();
    for ((k, num), token) in pieces {
        let x: f64 = num
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite())
            .ok_or_else(|| format!("'{token}' is not a letter and a finite number"))?;
        words.push((k, x));
    }
    Ok(Some((code, words)))
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

    #[test]
    fn words_are_read_with_or_without_spaces_and_comments_go() {
        let w = |s: &str| tokens(s).unwrap();
        let g1 = Some(("G1".to_string(), vec![('X', 1.5), ('Y', -2.0), ('E', 0.25)]));
        assert_eq!(w("G1 X1.5 Y-2 E0.25"), g1);
        assert_eq!(w("g1x1.5y-2e.25 ; comment"), g1);
        assert_eq!(w("N120 G1 X1.5 (note) Y-2 E0.25"), g1);
        assert_eq!(w("G43.4 H1"), Some(("G43.4".to_string(), vec![('H', 1.0)])));
        assert_eq!(w(" TRAORI "), Some(("TRAORI".to_string(), vec![])));
        assert_eq!(w("; only a comment"), None);
        // No exponents in G-code: E starts the next word.
        assert_eq!(
            w("G1 X1E5"),
            Some(("G1".to_string(), vec![('X', 1.0), ('E', 5.0)]))
        );
        for bad in ["G1 XNaN", "G1 X1e", "G1 X", "G1 *5", "G1 X1..2", "G1 Xinf"] {
            assert!(tokens(bad).is_err(), "{bad}");
        }
    }
}
