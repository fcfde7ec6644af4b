//! Which material exists while each line of a program runs.
//!
//! A program does not say what it prints; the toolpath's layer surfaces
//! say what the part is. A surface triangle belongs to its nearest
//! waypoint (the scene's stamps); a waypoint is printed from the moment
//! the program first extrudes at it: the waypoint nearest to the end of an
//! extruding move, the one nearest to its start when the bead starts on it
//! (within half a bead width), and the waypoints of the same layer between
//! those two that lie under its bead (within half a bead width of the
//! move's chord) — so a program that skips waypoints still prints them. Waypoints are numbered in the order they are first printed
//! (the program's own order, whatever the toolpath's), and the scene is
//! re-stamped with those numbers ([`Timeline::stamp`],
//! [`crate::scene::Scene::restamp`]).
//!
//! A move leaves out the material of the waypoint it leaves and of every
//! waypoint printed after it, as the planner's cutoffs do (a move from
//! waypoint `g` is proved against the stamps below `g`'s): the nozzle lays
//! that bead, or rests on it. The waypoint a line leaves is the one its
//! start tip stands on (within 5 µm): the one the nozzle last
//! arrived at, or a section's first, which the line starts printing. A
//! bead written as several lines (the lines from one that starts on a
//! waypoint to the first that ends on one, every end between under the
//! bead) leaves out the same material in each, the waypoint its first
//! line leaves, however the program splits it; so do the lines that leave
//! a waypoint without extruding (a lift, a turn on the spot). Every other
//! move sees all printed material, except an extruding line that starts
//! on no waypoint: it leaves out the last printed waypoint's.
//!
//! A line that splits a bead can end nearer to a waypoint of the layer
//! above (or below) than to either end of its bead. Such a line is not
//! printing that layer: where the lines of one extruding run read as
//! layer `L`, then as other layers, then as `L` again, the lines between
//! read as `L` and their ends as the nearest waypoint of `L` (`blips`).

use crate::io::gcode_read::{axes_of, GcodeMove};
use crate::kinematics::Machine;
use crate::plan::layer_reading::NearestLayer;
use crate::program_toolpath::ProgramToolpath;
use crate::scene::stamp_of;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;

/// Longest run of waypoints one extruding move may print at once.
const MAX_RUN: usize = 10_000;

/// A tip this close to a waypoint (mm) stands on it: a written program's
/// lines end within 2 µm of the waypoints they were planned to (three
/// decimals on five axes; ours and the data set's reference programs), the
/// points that split a bead lie 25 µm and more from every waypoint (the
/// tilted dome_cut's).
const ON_WAYPOINT: f64 = 0.005;

/// Most lines in a row [`blips`] reads as the layer around them: more than
/// one bead is ever split into.
const MAX_BLIP: usize = 8192;

/// When each waypoint is printed and what exists during each move.
#[derive(Clone, Debug, PartialEq)]
pub struct Timeline {
    /// Per waypoint (global index): its number in print order (`None`:
    /// never printed).
    pub printed: Vec<Option<u32>>,
    /// Per move: material with a re-stamped stamp below this exists.
    pub cutoffs: Vec<u32>,
    /// Per move: the layer it reads as (its end's nearest waypoint for
    /// extruding moves, else the last extruding move's; before the first,
    /// the first's). `None` when the program never extrudes.
    pub layers: Vec<Option<usize>>,
}

impl Timeline {
    /// The timeline of `moves` (as [`crate::io::gcode_read::read_program`]
    /// reads them, on machine `m`: only the lines' end tips count, so the
    /// interpolation does not matter) over waypoints at `pos` indexed by
    /// `reader`.
    pub fn new(m: &Machine, reader: &NearestLayer, pos: &[[f64; 3]], moves: &[GcodeMove]) -> Self {
        let mut printed: Vec<Option<u32>> = vec![None; pos.len()];
        let mut cutoffs = Vec::with_capacity(moves.len());
        let mut layers = Vec::with_capacity(moves.len());
        let mut count = 0u32;
        let mut last_layer = None;
        let half_width = 0.5 * m.extrusion.width;
        let ends = LineEnds::new(m, reader, moves);
        let reads = blips(reader, &ends, moves);
        let bead_ends = bead_ends(reader, &ends, &reads, moves);
        // The waypoint the nozzle stands on (printed), and the bead being
        // laid: its last line and the print number of the waypoint it left.
        let mut stood: Option<usize> = None;
        let mut bead: Option<(usize, u32)> = None;
        for (i, mv) in moves.iter().enumerate() {
            let (pa, pb) = (ends.starts[i], ends.tips[i]);
            let in_bead = bead.filter(|&(last, _)| i <= last).map(|(_, k)| k);
            if !mv.extrudes() || pos.is_empty() {
                // A piece of a bead, or leaving the waypoint the nozzle
                // stands on (a lift, a turn on the spot): without its
                // material; else all printed material.
                let leaves = in_bead.or_else(|| {
                    stood
                        .filter(|w| ends.at_start(i).contains(w))
                        .and_then(|w| printed[w])
                });
                cutoffs.push(leaves.map_or(count + 1, |k| k + 1));
                layers.push(last_layer);
                if mv.moves_axes() && !stood.is_some_and(|w| ends.stands_on(i).contains(&w)) {
                    stood = None;
                }
                continue;
            }
            let before = count;
            if let Some((a, b)) = bead_ends[i] {
                let prints = bead_waypoints(reader, pos, half_width, (a, pa), (b, pb));
                for w in prints {
                    if printed[w].is_none() {
                        printed[w] = Some(count);
                        count += 1;
                    }
                }
                last_layer = Some(reader.layer(b));
            }
            // The waypoint the bead leaves: the one the nozzle stands on, or
            // one this line starts printing at (a section's first).
            let leaves = in_bead.or_else(|| {
                let start = latest(&printed, ends.at_start(i), |w| {
                    Some(w) == stood || printed[w] >= Some(before)
                });
                let k = start.and_then(|w| printed[w])?;
                if let Some(last) = bead_end(&ends, moves, i, pa, half_width) {
                    bead = Some((last, k));
                }
                Some(k)
            });
            // Without the waypoint's material and all printed since; where
            // the line does not start on a waypoint, without the last
            // printed waypoint's.
            cutoffs.push(leaves.map_or(before, |k| k + 1));
            let since = leaves.unwrap_or(before);
            stood = latest(&printed, ends.stands_on(i), |w| printed[w] >= Some(since));
            layers.push(last_layer);
        }
        // Before the first extrusion a move reads as the first printed layer.
        if let Some(first) = layers.iter().flatten().next().copied() {
            for l in layers.iter_mut() {
                match l {
                    None => *l = Some(first),
                    Some(_) => break,
                }
            }
        }
        Timeline {
            printed,
            cutoffs,
            layers,
        }
    }

    /// The timeline of `moves` printing their own toolpath `pt` (read from
    /// them: [`ProgramToolpath::of`]), whose waypoint `g` lies in layer
    /// `layer_of[g]`: waypoints are printed in the toolpath's order, which
    /// is the program's, each bead by the line that ends on it, so the
    /// stamps need no change.
    pub fn of_program(pt: &ProgramToolpath, layer_of: &[usize], moves: &[GcodeMove]) -> Self {
        let n = pt.lines.len();
        let mut cutoffs = Vec::with_capacity(moves.len());
        let mut layers = Vec::with_capacity(moves.len());
        // Waypoints reached so far.
        let mut reached = 0usize;
        for (i, mv) in moves.iter().enumerate() {
            let at = pt.move_waypoint.get(i).copied().flatten();
            match at {
                // Laying the bead into g: all but the bead it starts on.
                Some(g) if mv.extrudes() && pt.printed[g] => cutoffs.push(stamp_of(g - 1)),
                // Everything printed before the line's end.
                _ => cutoffs.push(stamp_of(at.unwrap_or(reached))),
            }
            if let Some(g) = at {
                reached = g + 1;
            }
            layers.push(reached.checked_sub(1).map(|g| layer_of[g]));
        }
        // Before the first waypoint a move reads as the first layer.
        let first = layer_of.first().copied();
        for l in layers.iter_mut().take_while(|l| l.is_none()) {
            *l = first;
        }
        Timeline {
            printed: (0..n as u32).map(Some).collect(),
            cutoffs,
            layers,
        }
    }

    /// The re-stamped stamp of a scene triangle with stamp `s` (its
    /// waypoint's global index + 1): its waypoint's print number + 1, or
    /// never (`u32::MAX`).
    pub fn stamp(&self, s: u32) -> u32 {
        match self.printed.get(s as usize - 1) {
            Some(Some(k)) => k + 1,
            _ => u32::MAX,
        }
    }
}

/// Per move: the layer its end reads as when that is not the layer of the
/// waypoint nearest to it — lines of one extruding run that read as other
/// layers between lines that read as `L` read as `L`; `None` elsewhere.
fn blips(reader: &NearestLayer, ends: &LineEnds, moves: &[GcodeMove]) -> Vec<Option<usize>> {
    let mut fixed = vec![None; moves.len()];
    // In an extruding run: (the first line after the last one that read as
    // the run's layer, that layer); a run reads first as where it starts.
    let mut anchor: Option<(usize, usize)> = None;
    for (i, mv) in moves.iter().enumerate() {
        if !mv.extrudes() {
            anchor = None;
            continue;
        }
        if anchor.is_none() {
            anchor = ends.start_nearest[i].map(|g| (i, reader.layer(g)));
        }
        let (Some((from, run)), Some(layer)) = (anchor, ends.nearest[i].map(|g| reader.layer(g)))
        else {
            anchor = None;
            continue;
        };
        anchor = if layer == run {
            fixed[from..i].iter_mut().for_each(|f| *f = Some(run));
            Some((i + 1, run))
        } else if i + 1 - from > MAX_BLIP {
            // Another layer for longer than a bead's pieces: a real change.
            Some((i + 1, layer))
        } else {
            anchor
        };
    }
    fixed
}

/// Per extruding move: the waypoints nearest to its start and its end,
/// each of the layer it reads as ([`blips`]) where it reads as one,
/// looked up for every line in parallel; `None` for the other moves, or
/// where no waypoint is.
fn bead_ends(
    reader: &NearestLayer,
    ends: &LineEnds,
    reads: &[Option<usize>],
    moves: &[GcodeMove],
) -> Vec<Option<(usize, usize)>> {
    // The nearest waypoint of `layer` is the nearest of all when that
    // lies in `layer` (both take the earliest of equals).
    let near = |p, nearest: Option<usize>, read: Option<usize>| match (read, nearest) {
        (Some(l), Some(g)) if reader.layer(g) == l => Some(g),
        (Some(l), _) => reader.nearest_in(p, l),
        (None, _) => nearest,
    };
    (0..moves.len())
        .into_par_iter()
        .map(|i| {
            if !moves[i].extrudes() {
                return None;
            }
            let start_read = i.checked_sub(1).and_then(|j| reads[j]);
            let a = near(ends.starts[i], ends.start_nearest[i], start_read);
            let b = near(ends.tips[i], ends.nearest[i], reads[i]);
            a.zip(b)
        })
        .collect()
}

/// The waypoints an extruding line from the tip at `pa` (nearest
/// waypoint `a`) to `pb` (nearest `b`) prints, in print order: `a` when
/// the bead starts on it (the first of a section has no line ending on
/// it), those of the same layer strictly between that lie under the bead,
/// and `b`.
fn bead_waypoints(
    reader: &NearestLayer,
    pos: &[[f64; 3]],
    half_width: f64,
    (a, pa): (usize, [f64; 3]),
    (b, pb): (usize, [f64; 3]),
) -> Vec<usize> {
    let mut out = Vec::new();
    let same_layer = reader.layer(a) == reader.layer(b);
    // (A segment of length 0: the distance to the start tip.)
    if same_layer && distance_to_segment(pos[a], pa, pa) <= half_width {
        out.push(a);
    }
    if same_layer && a != b && a.abs_diff(b) <= MAX_RUN {
        let between = (1..a.abs_diff(b)).map(|k| if a < b { a + k } else { a - k });
        out.extend(between.filter(|&w| distance_to_segment(pos[w], pa, pb) <= half_width));
    }
    out.push(b);
    out
}

/// Each line's start and end tips, the waypoints nearest to them and the
/// waypoints they stand on (within [`ON_WAYPOINT`]; several where
/// waypoints coincide), looked up once for every line in parallel; a line
/// that starts where the one before ends shares that line's end.
struct LineEnds {
    starts: Vec<[f64; 3]>,
    tips: Vec<[f64; 3]>,
    start_nearest: Vec<Option<usize>>,
    nearest: Vec<Option<usize>>,
    /// Line `i`'s start tip stands on `on[start_on[i]]`, its end tip on
    /// `on[end_on[i]]`.
    start_on: Vec<Range<usize>>,
    end_on: Vec<Range<usize>>,
    on: Vec<usize>,
}

/// A tip, the waypoints it stands on and the waypoint nearest to it.
type TipLookup = ([f64; 3], Vec<usize>, Option<usize>);

impl LineEnds {
    fn new(m: &Machine, reader: &NearestLayer, moves: &[GcodeMove]) -> Self {
        let look = |axes: &[f64; 5]| -> TipLookup {
            let tip = m.tip(&axes_of(axes));
            let (on, nearest) = reader.within_and_nearest(tip, ON_WAYPOINT);
            (tip, on, nearest)
        };
        let per: Vec<(Option<TipLookup>, TipLookup)> = (0..moves.len())
            .into_par_iter()
            .map(|i| {
                let start = continues(moves, i).is_none().then(|| look(&moves[i].from));
                (start, look(&moves[i].to))
            })
            .collect();
        let n = moves.len();
        let mut ends = LineEnds {
            starts: Vec::with_capacity(n),
            tips: Vec::with_capacity(n),
            start_nearest: Vec::with_capacity(n),
            nearest: Vec::with_capacity(n),
            start_on: Vec::with_capacity(n),
            end_on: Vec::with_capacity(n),
            on: Vec::new(),
        };
        for (start, (tip, on, nearest)) in per {
            let (start, start_on, start_nearest) = match start {
                Some((start, on, nearest)) => (start, ends.keep(on), nearest),
                None => {
                    let h = ends.tips.len() - 1;
                    (ends.tips[h], ends.end_on[h].clone(), ends.nearest[h])
                }
            };
            ends.starts.push(start);
            ends.start_on.push(start_on);
            ends.start_nearest.push(start_nearest);
            ends.tips.push(tip);
            let end_on = ends.keep(on);
            ends.end_on.push(end_on);
            ends.nearest.push(nearest);
        }
        ends
    }

    /// `waypoints` kept in `on`, and where.
    fn keep(&mut self, waypoints: Vec<usize>) -> Range<usize> {
        let from = self.on.len();
        self.on.extend(waypoints);
        from..self.on.len()
    }

    /// The waypoints line `i`'s start tip stands on.
    fn at_start(&self, i: usize) -> &[usize] {
        &self.on[self.start_on[i].clone()]
    }

    /// The waypoints line `i`'s end tip stands on.
    fn stands_on(&self, i: usize) -> &[usize] {
        &self.on[self.end_on[i].clone()]
    }
}

/// The line before line `i` when `i` starts where it ends.
fn continues(moves: &[GcodeMove], i: usize) -> Option<usize> {
    i.checked_sub(1).filter(|&h| moves[h].to == moves[i].from)
}

/// Of the printed waypoints `on` (those a tip stands on) that `ok`
/// accepts, the one printed last.
fn latest(printed: &[Option<u32>], on: &[usize], ok: impl Fn(usize) -> bool) -> Option<usize> {
    on.iter()
        .copied()
        .filter(|&w| printed[w].is_some() && ok(w))
        .max_by_key(|&w| printed[w])
}

/// The last line of the bead that line `i` starts at the tip `start`: the
/// lines from `i` on (extruding, or moving with the written E unchanged,
/// as the pieces of a bead of no length do: a turn on the spot) up to the
/// first whose end stands on a waypoint, when every end before it lies
/// under the bead (within `half_width` of the chord from `start` to that
/// end); `None` when something else comes first.
fn bead_end(
    ends: &LineEnds,
    moves: &[GcodeMove],
    i: usize,
    start: [f64; 3],
    half_width: f64,
) -> Option<usize> {
    for (j, mv) in moves.iter().enumerate().skip(i).take(MAX_BLIP) {
        let along = mv.extrudes() || (mv.linear && mv.de == 0.0 && mv.moves_axes());
        if !along {
            return None;
        }
        let end = ends.tips[j];
        if !ends.stands_on(j).is_empty() {
            return ends.tips[i..j]
                .iter()
                .all(|&p| distance_to_segment(p, start, end) <= half_width)
                .then_some(j);
        }
    }
    None
}

/// Distance from `p` to the segment `a b`.
fn distance_to_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (p, a, b) = (DVec3::from(p), DVec3::from(a), DVec3::from(b));
    let (ab, ap) = (b - a, p - a);
    let l2 = ab.dot(ab);
    let u = if l2 > 0.0 {
        (ap.dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (ap - ab * u).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mv(from: [f64; 3], to: [f64; 3], de: f64) -> GcodeMove {
        GcodeMove {
            line: 1,
            linear: true,
            from: [from[0], from[1], from[2], 0.0, 0.0],
            to: [to[0], to[1], to[2], 0.0, 0.0],
            e: 0.0,
            de,
            f: 1500.0,
            inverse_time: false,
            tcp: false,
            tool: 1,
            dwell: 0.0,
        }
    }

    #[test]
    fn material_appears_in_the_programs_order_and_the_bead_under_the_nozzle_waits() {
        // One layer of five waypoints 1 mm apart along x, printed from the
        // far end back, skipping waypoint 2 (its bead covers it); a sixth
        // waypoint far off is never printed.
        let mut pos: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        pos.push([20.0, 0.0, 0.0]);
        let reader = NearestLayer::new(&pos, &[0; 6]);
        let m = Machine::default();
        let moves = [
            mv([9.0, 0.0, 5.0], [4.0, 0.0, 0.0], 0.0), // approach, no material yet
            mv([4.0, 0.0, 0.0], [3.0, 0.0, 0.0], 0.5),
            mv([3.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0),
            mv([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.5),
            mv([0.0, 0.0, 0.0], [0.0, 0.0, 5.0], 0.0), // lift
        ];
        let t = Timeline::new(&m, &reader, &pos, &moves);
        // The bead starts on 4, then 3; 2 under the bead and 1; then 0.
        assert_eq!(
            t.printed,
            vec![Some(4), Some(3), Some(2), Some(1), Some(0), None]
        );
        // The approach sees all printed material (none yet); a bead leaves
        // out the waypoint it starts on and what is printed after it (the
        // first: nothing is printed before it), so does the lift (the
        // nozzle stands on waypoint 0).
        assert_eq!(t.cutoffs, vec![1, 1, 2, 4, 5]);
        // Stamp s = waypoint + 1 → print number + 1.
        assert_eq!(t.stamp(4), 2); // waypoint 3
        assert_eq!(t.stamp(6), u32::MAX); // waypoint 5
        assert_eq!(t.layers, vec![Some(0); 5]);
    }

    #[test]
    fn a_split_point_nearer_the_layer_above_prints_nothing_of_it() {
        // Layer 0: waypoints 0 and 1, 1.2 mm apart, and 2 far on; layer 1:
        // waypoint 3, 0.3 mm above the middle of the bead from 0 to 1.
        let pos = [
            [0.0, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [2.4, 0.0, 0.0],
            [0.6, 0.0, 0.3],
        ];
        let reader = NearestLayer::new(&pos, &[0, 0, 0, 1]);
        let m = Machine::default();
        let moves = [
            mv([0.0, 0.0, 0.0], [0.6, 0.0, 0.0], 0.3), // ends nearest to 3
            mv([0.6, 0.0, 0.0], [1.2, 0.0, 0.0], 0.3),
            mv([1.2, 0.0, 0.0], [2.4, 0.0, 0.0], 0.6),
        ];
        assert_eq!(reader.nearest([0.6, 0.0, 0.0]), Some(3));
        let t = Timeline::new(&m, &reader, &pos, &moves);
        assert_eq!(t.printed, vec![Some(0), Some(1), Some(2), None]);
        assert_eq!(t.layers, vec![Some(0); 3]);
        // The first two lines are one bead, from waypoint 0.
        assert_eq!(t.cutoffs, vec![1, 1, 2]);
    }

    /// A line from the tip at `pa` with C at `ca`° to `pb` with C at
    /// `cb`° (tilt 0) on machine `m`, laying `de` of filament; `G1` when
    /// `linear`, else `G0`.
    fn line(
        m: &Machine,
        (pa, ca): ([f64; 3], f64),
        (pb, cb): ([f64; 3], f64),
        de: f64,
        linear: bool,
    ) -> GcodeMove {
        let axes = |p, c: f64| {
            let a = m.axes_at(p, (0.0, c.to_radians()));
            [a.xyz[0], a.xyz[1], a.xyz[2], 0.0, a.c.to_degrees()]
        };
        GcodeMove {
            linear,
            from: axes(pa, ca),
            to: axes(pb, cb),
            ..mv([0.0; 3], [0.0; 3], de)
        }
    }

    #[test]
    fn a_move_leaves_out_the_waypoint_it_leaves_however_the_program_splits_it() {
        // Five waypoints 1 mm apart along x. The program prints 0 → 2, the
        // bead into 1 in four lines (the third ends nearest to 1), turns C
        // on the spot at 2 in two lines without extruding, lifts, travels
        // and prints 4 → 3.
        let pos: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        let reader = NearestLayer::new(&pos, &[0; 5]);
        let m = Machine::default();
        let x = |x: f64, z: f64| [x, 0.0, z];
        let moves = [
            line(&m, (x(0.0, 5.0), 0.0), (x(0.0, 0.0), 0.0), 0.0, true), // approach
            line(&m, (x(0.0, 0.0), 0.0), (x(0.3, 0.0), 0.0), 0.1, true),
            line(&m, (x(0.3, 0.0), 0.0), (x(0.6, 0.0), 0.0), 0.1, true),
            line(&m, (x(0.6, 0.0), 0.0), (x(0.8, 0.0), 0.0), 0.1, true),
            line(&m, (x(0.8, 0.0), 0.0), (x(1.0, 0.0), 0.0), 0.1, true),
            line(&m, (x(1.0, 0.0), 0.0), (x(2.0, 0.0), 0.0), 0.3, true),
            line(&m, (x(2.0, 0.0), 0.0), (x(2.0, 0.0), 30.0), 0.0, true), // turn
            line(&m, (x(2.0, 0.0), 30.0), (x(2.0, 0.0), 60.0), 0.0, true),
            line(&m, (x(2.0, 0.0), 60.0), (x(2.0, 5.0), 60.0), 0.0, false), // lift
            line(&m, (x(2.0, 5.0), 60.0), (x(4.0, 5.0), 0.0), 0.0, false),  // travel
            line(&m, (x(4.0, 5.0), 0.0), (x(4.0, 0.0), 0.0), 0.0, true),    // approach
            line(&m, (x(4.0, 0.0), 0.0), (x(3.0, 0.0), 0.0), 0.3, true),
        ];
        let t = Timeline::new(&m, &reader, &pos, &moves);
        assert_eq!(t.printed, vec![Some(0), Some(1), Some(2), Some(4), Some(3)]);
        assert_eq!(
            t.cutoffs,
            vec![
                1, // nothing printed yet
                1, 1, 1, 1, // the bead from 0: without 0 (and 1) in every line
                2, // from 1: 0 exists
                3, 3, 3, // the turn and the lift leave 2: without it
                4, 4, // off the part: everything printed
                4, // from 4, a section's first: 0 to 2 exist
            ]
        );
    }

    #[test]
    fn lines_that_never_stand_on_a_waypoint_leave_out_the_last_printed() {
        // A program printing beside a row of waypoints, its lines ending
        // half-way between them: no line starts or ends on one.
        let pos: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        let reader = NearestLayer::new(&pos, &[0; 5]);
        let m = Machine::default();
        let moves: Vec<GcodeMove> = (0..4)
            .map(|i| {
                let y = [0.5 + i as f64, 0.1, 0.0];
                mv(y, [y[0] + 1.0, 0.1, 0.0], 0.3)
            })
            .collect();
        let t = Timeline::new(&m, &reader, &pos, &moves);
        assert_eq!(t.printed, vec![None, Some(0), Some(1), Some(2), Some(3)]);
        assert_eq!(t.cutoffs, vec![0, 1, 2, 3]);
    }
}
