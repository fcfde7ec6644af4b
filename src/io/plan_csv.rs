//! `plan.csv`: one row per waypoint with its position, planned orientation,
//! machine axes as written, extrusion, layer height and flags; and reading
//! it back (for `check --plan`).
//!
//! Flags: `section_start` (a travel comes before it), `break` (entered
//! through a break inside a section), `was_colliding` (the input
//! orientation comes within the margin), `was_singular` / `singular` (the
//! input / planned orientation lies in the singular region, |tilt| ≤ α —
//! `report.json` counts the same flags), `skipped` (empty when visited,
//! else `residual`, `unreachable` or `isolated`; skipped rows have no axes).

use super::fixed::push_fixed;
use super::{read_to_string, InputError};
use crate::kinematics::{Machine, Rotary};
use crate::plan::{PlannedWaypoint, Skip};
use rayon::prelude::*;
use std::fmt::Write;
use std::path::Path;

/// The CSV text (rows formatted in parallel, in blocks, then joined in
/// order: the text is the same on any number of threads).
pub fn write_plan_csv(m: &Machine, w: &[PlannedWaypoint]) -> String {
    let tl = if m.rotary == Rotary::AC { "A" } else { "B" };
    let mut s = format!(
        "index,layer,px,py,pz,nx,ny,nz,X,Y,Z,{tl},C,E,height,section_start,break,was_colliding,was_singular,singular,skipped\n"
    );
    const BLOCK: usize = 4096;
    let blocks: Vec<String> = w
        .par_chunks(BLOCK)
        .enumerate()
        .map(|(b, rows)| {
            let mut out = String::with_capacity(rows.len() * 128);
            for (k, p) in rows.iter().enumerate() {
                row(&mut out, b * BLOCK + k, p);
            }
            out
        })
        .collect();
    s.reserve(blocks.iter().map(String::len).sum());
    for b in &blocks {
        s.push_str(b);
    }
    s
}

/// Row `i` of the CSV, for waypoint `p`.
fn row(s: &mut String, i: usize, p: &PlannedWaypoint) {
    let a = &p.axes;
    let skipped = match p.skipped {
        None => "",
        Some(Skip::Residual) => "residual",
        Some(Skip::Unreachable) => "unreachable",
        Some(Skip::Isolated) => "isolated",
    };
    let _ = write!(s, "{i},{},", p.layer);
    for v in &p.p {
        push_fixed(s, *v, 4);
        s.push(',');
    }
    for v in &p.n {
        push_fixed(s, *v, 6);
        s.push(',');
    }
    if p.skipped.is_some() {
        s.push_str(",,,,");
    } else {
        let written = [
            a.xyz[0],
            a.xyz[1],
            a.xyz[2],
            a.tilt.to_degrees(),
            a.c.to_degrees(),
        ];
        for (k, v) in written.iter().enumerate() {
            if k > 0 {
                s.push(',');
            }
            push_fixed(s, *v, 3);
        }
    }
    s.push(',');
    push_fixed(s, p.e, 3);
    s.push(',');
    push_fixed(s, p.height, 4);
    let _ = writeln!(
        s,
        ",{},{},{},{},{},{skipped}",
        p.section_start as u8,
        p.break_before as u8,
        p.was_colliding as u8,
        p.was_singular as u8,
        p.singular as u8,
    );
}

/// One row of a plan CSV as `check --plan` needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanRow {
    /// `[X, Y, Z, tilt°, C°]`, `None` for a skipped waypoint.
    pub axes: Option<[f64; 5]>,
    /// A travel comes before this row (section start or break).
    pub travel_before: bool,
}

/// Read the rows of a plan CSV.
pub fn read_plan(path: &Path) -> Result<Vec<PlanRow>, InputError> {
    let text = read_to_string(path)?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |names: &[&str]| header.iter().position(|h| names.contains(h));
    let idx: Vec<usize> = [&["X"][..], &["Y"], &["Z"], &["B", "A"], &["C"]]
        .iter()
        .map(|n| col(n))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| InputError::at(path, 1, "header needs columns X, Y, Z, B (or A) and C: give a plan.csv written by `maamplan plan`"))?;
    let flag = |names: &[&str]| col(names);
    let (start_col, break_col, skip_col) = (
        flag(&["section_start"]),
        flag(&["break"]),
        flag(&["skipped"]),
    );
    let mut out = Vec::new();
    for (i, l) in lines.enumerate() {
        if l.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = l.split(',').collect();
        let get = |c: Option<usize>| c.and_then(|c| f.get(c)).map(|s| s.trim()).unwrap_or("");
        let skipped = !get(skip_col).is_empty();
        let axes = if skipped {
            None
        } else {
            let mut v = [0.0; 5];
            for (k, &c) in idx.iter().enumerate() {
                v[k] = f
                    .get(c)
                    .and_then(|x| x.parse().ok())
                    .filter(|x: &f64| x.is_finite())
                    .ok_or_else(|| {
                        InputError::at(
                            path,
                            i + 2,
                            format!(
                                "column {} is missing or not a finite number: fix this row",
                                header[c]
                            ),
                        )
                    })?;
            }
            Some(v)
        };
        out.push(PlanRow {
            axes,
            travel_before: get(start_col) == "1" || get(break_col) == "1",
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Axes;

    /// Rows formatted block by block come out as one plain loop writes
    /// them: in order across block boundaries, one line per waypoint.
    #[test]
    fn rows_follow_the_waypoints_across_blocks() {
        let m = Machine::default();
        let w: Vec<PlannedWaypoint> = (0..10_000)
            .map(|i| PlannedWaypoint {
                layer: i / 100,
                support: false,
                p: [i as f64 * 0.5, 1.0, 2.0],
                n: [0.0, 0.0, 1.0],
                axes: Axes::default(),
                e: i as f64 * 0.01,
                height: 0.4,
                section_start: i % 100 == 0,
                break_before: false,
                was_colliding: i % 7 == 0,
                was_singular: false,
                singular: false,
                skipped: (i % 1000 == 999).then_some(Skip::Residual),
            })
            .collect();
        let text = write_plan_csv(&m, &w);
        let mut plain = String::new();
        for (i, p) in w.iter().enumerate() {
            row(&mut plain, i, p);
        }
        let body = text.split_once('\n').unwrap().1;
        assert_eq!(body, plain);
        for (i, line) in body.lines().enumerate() {
            assert!(line.starts_with(&format!("{i},")), "row {i}: {line}");
        }
        assert_eq!(body.lines().count(), w.len());
    }
}
