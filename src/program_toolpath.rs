//! A G-code program's own toolpath: the tip path and nozzle directions it
//! prints along, recovered through the machine's kinematics, in its
//! layers, each waypoint with the program line it comes from. `plan`
//! re-plans a program from it and `simulate` checks a program against the
//! beads it lays itself.
//!
//! **Waypoints.** A printing run is what the program does between two
//! travels: it starts with the first extruding `G1` after one, at that
//! line's start, and each `G1` of the run adds its end. A run goes on
//! over `G1` lines that move without extruding (no more than
//! [`DEFAULT_GAP`], not along the nozzle: a short crossing, or the last
//! waypoint of a layer written with no filament), over primes, dwells and
//! lines that set only modes; a retract, a `G0`, a longer or along-the-
//! nozzle `G1` without filament, or a tool change ends it. An extruding
//! move along the nozzle before a run's first bead (within [`APPROACH_DEG`]
//! of the axis: the approach onto the part that some programs extrude
//! on) is no bead: the run starts at its end. Each waypoint keeps whether
//! the program extruded along the segment into it ([`ProgramToolpath::printed`]).
//!
//! **Layers** come from the program's layer-change comments (`;LAYER:3`,
//! `;LAYER_CHANGE`, `; layer 3`: [`crate::io::gcode_words::is_layer_change`]);
//! without any, from how the beads stack ([`beads::stacked_layers`]). A
//! layer all of whose waypoints the support tool prints is a support layer
//! (named `…S`).
//!
//! **Sections.** A planner joins consecutive waypoints of a layer up to a
//! distance (`jump`); [`ProgramToolpath::sections`] finds the distance that
//! joins every segment of the program's runs and none of its travels, so
//! the re-planned program prints where the program did.

use crate::geometry::Mesh;
use crate::io::gcode_read::{axes_of, load_program, GcodeMove, Program};
use crate::io::{InputError, Placement};
use crate::kinematics::{forward, Machine};
use crate::scene::beads::{self, BeadSettings, DEFAULT_GAP};
use crate::scene::{stamp_of, PartGroup};
use crate::toolpath::{Layer, Toolpath, Waypoint};
use glam::DVec3;
use std::path::Path;

/// Largest angle (degrees) between an extruding move and the nozzle axis
/// at which the move is an approach onto the part (or a lift off it)
/// rather than a bead.
pub const APPROACH_DEG: f64 = 20.0;

/// The toolpath a program prints.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProgramToolpath {
    /// The waypoints in print order (part frame: the machine's), in the
    /// layers the comments give, else in one layer.
    pub toolpath: Toolpath,
    /// Per waypoint: the 1-based program line it comes from — the line
    /// that ends there, or for a run's first waypoint the line that starts
    /// printing from it.
    pub lines: Vec<usize>,
    /// Per waypoint: the program extruded along the segment into it.
    pub printed: Vec<bool>,
    /// Per waypoint: the segment into it belongs to a printing run (it is
    /// printed, or crossed without filament between beads).
    pub in_run: Vec<bool>,
    /// Per waypoint: the tool printing it.
    pub tools: Vec<u32>,
    /// Per line of [`Program::moves`]: the waypoint it ends at, for the
    /// lines that make one.
    pub move_waypoint: Vec<Option<usize>>,
    /// The layers come from the program's layer-change comments.
    pub layers_from_comments: bool,
}

/// A program's toolpath in its layers, and the beads along its runs.
#[derive(Clone, Debug)]
pub struct Deposited {
    /// The waypoints in their layers (the program's order).
    pub toolpath: Toolpath,
    /// The beads of every segment of the program's runs, a group per layer.
    pub groups: Vec<PartGroup>,
}

/// The distance that separates a program's sections ([`ProgramToolpath::sections`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sections {
    /// Consecutive waypoints of a layer farther apart than this start a
    /// new section (mm); no shorter than the longest segment of a run.
    pub jump: f64,
    /// Travels within a layer no longer than `jump` (a re-plan prints
    /// along them): none when the runs' segments are all shorter than the
    /// travels.
    pub bridged: usize,
}

/// One waypoint while it is recovered.
struct Point {
    pos: [f64; 3],
    dir: [f64; 3],
    line: usize,
    printed: bool,
    in_run: bool,
    tool: u32,
    /// The line of moves it ends, if any.
    ends: Option<usize>,
}

impl ProgramToolpath {
    /// The toolpath of the program in the file at `path`, read for machine `m`.
    pub fn load(path: &Path, m: &Machine) -> Result<ProgramToolpath, InputError> {
        let program = load_program(path, m)?;
        let pt = ProgramToolpath::of(&program, m);
        if pt.toolpath.waypoint_count() == 0 {
            return Err(InputError::file(
                path,
                "the program never extrudes while it moves (G1 with a growing E): there is no toolpath to take from it",
            ));
        }
        Ok(pt)
    }

    /// The toolpath moved by `place` (`--y-up`, `--place`), as a toolpath
    /// file is.
    pub fn placed(mut self, place: &Placement) -> ProgramToolpath {
        for l in &mut self.toolpath.layers {
            for w in &mut l.waypoints {
                w.pos = place.point(w.pos);
                w.dir = place.direction(w.dir);
            }
        }
        self
    }

    /// The toolpath `program` prints on machine `m`.
    pub fn of(program: &Program, m: &Machine) -> ProgramToolpath {
        let points = recover(&program.moves, m);
        let mut move_waypoint = vec![None; program.moves.len()];
        for (g, p) in points.iter().enumerate() {
            if let Some(i) = p.ends {
                move_waypoint[i] = Some(g);
            }
        }
        // Layer k: the waypoints after k layer-change comments (those
        // before the first print none).
        let marks = &program.layer_marks;
        let mark_count: Vec<usize> = points
            .iter()
            .map(|p| marks.partition_point(|&l| l < p.line))
            .collect();
        let mut layers: Vec<Layer> = Vec::new();
        for (g, p) in points.iter().enumerate() {
            if g == 0 || mark_count[g] != mark_count[g - 1] {
                layers.push(Layer::default());
            }
            let layer = layers.last_mut().expect("a layer");
            layer.waypoints.push(Waypoint {
                pos: p.pos.map(|x| x as f32),
                dir: p.dir.map(|x| x as f32),
            });
        }
        let mut pt = ProgramToolpath {
            lines: points.iter().map(|p| p.line).collect(),
            printed: points.iter().map(|p| p.printed).collect(),
            in_run: points.iter().map(|p| p.in_run).collect(),
            tools: points.iter().map(|p| p.tool).collect(),
            layers_from_comments: layers.len() > 1 || !marks.is_empty(),
            toolpath: Toolpath { layers },
            move_waypoint,
        };
        for (k, l) in pt.toolpath.layers.iter_mut().enumerate() {
            l.name = k.to_string();
        }
        pt.name_support_layers(support_tool(m));
        pt
    }

    /// Name the layers of `self.toolpath` `k` or, where `support` says
    /// every waypoint's tool is the support extruder, `kS`.
    fn name_support_layers(&mut self, support: impl Fn(u32) -> bool) {
        let mut g = 0;
        for (k, l) in self.toolpath.layers.iter_mut().enumerate() {
            let n = l.waypoints.len();
            let all = n > 0 && self.tools[g..g + n].iter().all(|&t| support(t));
            l.name = if all { format!("{k}S") } else { k.to_string() };
            g += n;
        }
    }

    /// The longest segment of the program's runs (mm, as the toolpath
    /// stores the waypoints): beads must join segments this long.
    pub fn longest_segment(&self) -> f64 {
        let pos = self.toolpath.positions();
        (1..pos.len())
            .filter(|&g| self.in_run[g])
            .map(|g| dist(pos[g - 1], pos[g]))
            .fold(0.0, f64::max)
    }

    /// The shortest distance that joins every segment of the program's
    /// runs, with room for the rounding of the f32 positions a planner
    /// measures them from.
    fn joining(&self) -> f64 {
        self.longest_segment() * (1.0 + 1e-6) + 1e-6
    }

    /// The bead settings `s` joining every segment of the program's runs.
    pub fn bead_settings(&self, s: &BeadSettings) -> BeadSettings {
        BeadSettings {
            gap: self.joining(),
            ..*s
        }
    }

    /// The toolpath in its layers (the comments', else those its beads
    /// stack in) and the beads along every segment of its runs on
    /// `platform`, as `s` makes them (their gap from [`Self::bead_settings`]).
    pub fn deposit(&self, platform: &Mesh, s: &BeadSettings, m: &Machine) -> Deposited {
        let s = self.bead_settings(s);
        let held = beads::HeldPath::of(&self.toolpath);
        let path = held.path();
        if self.layers_from_comments || self.toolpath.waypoint_count() == 0 {
            return Deposited {
                toolpath: self.toolpath.clone(),
                groups: beads::deposit(path, platform, &s).groups,
            };
        }
        let stacking = beads::stacked_layers(path, platform, &s);
        let mut relayered = ProgramToolpath {
            toolpath: self.toolpath.relayered(&stacking.layer_of),
            ..self.clone()
        };
        relayered.name_support_layers(support_tool(m));
        Deposited {
            toolpath: relayered.toolpath,
            groups: stacking.deposit.groups,
        }
    }

    /// `groups` ([`Self::deposit`]'s) without the beads of segments the
    /// program crosses without extruding: the material it really lays.
    pub fn printed_only(&self, mut groups: Vec<PartGroup>) -> Vec<PartGroup> {
        // A bead's stamp is `stamp_of` the waypoint it ends at.
        let keep = |stamp: u32| {
            (stamp as usize)
                .checked_sub(stamp_of(0) as usize)
                .and_then(|g| self.printed.get(g))
                .is_some_and(|&p| p)
        };
        for grp in &mut groups {
            // A bead's triangles all carry its stamp: whole beads go.
            grp.retain_stamps(keep);
        }
        groups.retain(|grp| !grp.stamps.is_empty());
        groups
    }

    /// The section distance for `layered` (this toolpath in its final
    /// layers, [`Deposited::toolpath`]): [`DEFAULT_GAP`] where that joins
    /// every segment of a run and no travel within a layer; else a
    /// distance between the longest such segment and the shortest such
    /// travel; where none lies between, the longest segment (and the
    /// shorter travels are counted in [`Sections::bridged`]).
    pub fn sections(&self, layered: &Toolpath) -> Sections {
        let pos = layered.positions();
        let layer: Vec<usize> = layered.iter().map(|(k, _)| k).collect();
        let at_least = self.joining();
        let travels: Vec<f64> = (1..pos.len())
            .filter(|&g| !self.in_run[g] && layer[g] == layer[g - 1])
            .map(|g| dist(pos[g - 1], pos[g]))
            .collect();
        let shortest = travels.iter().copied().fold(f64::INFINITY, f64::min);
        let jump = if shortest > DEFAULT_GAP.max(at_least) {
            DEFAULT_GAP.max(at_least)
        } else if shortest > at_least {
            0.5 * (at_least + shortest)
        } else {
            at_least
        };
        Sections {
            jump,
            bridged: travels.iter().filter(|&&d| d <= jump).count(),
        }
    }
}

/// Is a tool machine `m`'s support extruder (and not its model one)?
fn support_tool(m: &Machine) -> impl Fn(u32) -> bool + '_ {
    |t| t == m.support.tool && t != m.extrusion.tool
}

/// The waypoints of `moves` on machine `m` (module doc).
fn recover(moves: &[GcodeMove], m: &Machine) -> Vec<Point> {
    let approach = APPROACH_DEG.to_radians().cos();
    let mut out: Vec<Point> = Vec::new();
    // In a run: its tool; and the lines crossed without filament since
    // its last bead.
    let mut run: Option<u32> = None;
    let mut pending: Vec<usize> = Vec::new();
    let point = |i: usize, end: bool, printed: bool| {
        let mv = &moves[i];
        let (tip, dir) = forward(m, &axes_of(if end { &mv.to } else { &mv.from }));
        Point {
            pos: tip,
            dir,
            line: mv.line,
            printed,
            in_run: printed,
            tool: mv.tool,
            ends: end.then_some(i),
        }
    };
    for (i, mv) in moves.iter().enumerate() {
        if !mv.moves_axes() {
            // A retract ends a run; primes, dwells and modes do not.
            if mv.de < 0.0 {
                flush(&mut out, &mut pending, &point);
                run = None;
            }
            continue;
        }
        let (a, n) = forward(m, &axes_of(&mv.from));
        let chord = DVec3::from(m.tip(&axes_of(&mv.to))) - DVec3::from(a);
        let along =
            chord.length() > 1e-9 && chord.normalize().dot(DVec3::from(n)).abs() >= approach;
        if mv.extrudes() && run.is_some_and(|t| t == mv.tool) {
            flush(&mut out, &mut pending, &point);
            out.push(point(i, true, true));
        } else if mv.extrudes() && !along {
            flush(&mut out, &mut pending, &point);
            run = Some(mv.tool);
            out.push(point(i, false, false));
            out.push(point(i, true, true));
        } else if mv.linear
            && mv.de.abs() <= 1e-9
            && run.is_some()
            && !along
            && chord.length() <= DEFAULT_GAP
        {
            pending.push(i);
        } else {
            flush(&mut out, &mut pending, &point);
            run = None;
        }
    }
    flush(&mut out, &mut pending, &point);
    out
}

/// The lines crossed without filament at the end of a run (or between
/// its beads) become waypoints the run goes through.
fn flush(
    out: &mut Vec<Point>,
    pending: &mut Vec<usize>,
    point: &impl Fn(usize, bool, bool) -> Point,
) {
    for i in pending.drain(..) {
        let mut p = point(i, true, false);
        p.in_run = true;
        out.push(p);
    }
}

/// Does the file at `path` hold a G-code program rather than waypoints?
/// Its extension says so (`.gcode`, `.nc`, `.ngc`, …), or its first line
/// that is not blank: a comment as programs write them (`;`, `(`, `%`) or
/// a word such as `G28`, `M104`, `T1`, `N10` — never a number, a `#`
/// comment or a column header, as waypoint files begin.
pub fn looks_like_program(path: &Path) -> bool {
    const EXTENSIONS: [&str; 9] = ["gcode", "gco", "g", "nc", "ngc", "tap", "mpf", "cnc", "eia"];
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.is_some_and(|e| EXTENSIONS.contains(&e.as_str())) {
        return true;
    }
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    use std::io::{BufRead, Read};
    let reader = std::io::BufReader::new(file.take(1 << 16));
    for line in reader.lines() {
        let Ok(line) = line else {
            return false;
        };
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        let mut chars = t.chars();
        let first = chars.next().map(|c| c.to_ascii_uppercase());
        return match first {
            Some(';' | '(' | '%') => true,
            Some('G' | 'M' | 'T' | 'N') => chars.next().is_some_and(|c| c.is_ascii_digit()),
            _ => false,
        };
    }
    false
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (DVec3::from(a) - DVec3::from(b)).length()
}
