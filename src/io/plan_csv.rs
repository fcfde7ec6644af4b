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

use super::{read_to_string, InputError};
use crate::kinematics::{Machine, Rotary};
use crate::plan::{PlannedWaypoint, Skip};
use std::fmt::Write;
use std::path::Path;

/// The CSV text.
pub fn write_plan_csv(m: &Machine, w: &[PlannedWaypoint]) -> String {
    let tl = if m.rotary == Rotary::AC { "A" } else { "B" };
    let mut s = format!(
        "index,layer,px,py,pz,nx,ny,nz,X,Y,Z,{tl},C,E,height,section_start,break,was_colliding,was_singular,singular,skipped\n"
    );
    for (i, p) in w.iter().enumerate() {
        let a = &p.axes;
        let axes = if p.skipped.is_some() {
            ",,,,".to_string()
        } else {
            format!(
                "{:.3},{:.3},{:.3},{:.3},{:.3}",
                a.xyz[0],
                a.xyz[1],
                a.xyz[2],
                a.tilt.to_degrees(),
                a.c.to_degrees()
            )
        };
        let skipped = match p.skipped {
            None => "",
            Some(Skip::Residual) => "residual",
            Some(Skip::Unreachable) => "unreachable",
            Some(Skip::Isolated) => "isolated",
        };
        let _ = writeln!(
            s,
            "{i},{},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{axes},{:.3},{:.4},{},{},{},{},{},{skipped}",
            p.layer,
            p.p[0],
            p.p[1],
            p.p[2],
            p.n[0],
            p.n[1],
            p.n[2],
            p.e,
            p.height,
            p.section_start as u8,
            p.break_before as u8,
            p.was_colliding as u8,
            p.was_singular as u8,
            p.singular as u8,
        );
    }
    s
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
