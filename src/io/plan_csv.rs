//! `plan.csv`: one row per waypoint with its position, planned orientation,
//! machine axes, extrusion and flags; and reading the axes back (for
//! `check --plan`).

use super::{read_to_string, InputError};
use crate::kinematics::{Machine, Rotary};
use crate::plan::PlannedWaypoint;
use std::fmt::Write;
use std::path::Path;

/// The CSV text.
pub fn write_plan_csv(m: &Machine, w: &[PlannedWaypoint]) -> String {
    let tl = if m.rotary == Rotary::AC { "A" } else { "B" };
    let mut s = format!(
        "index,layer,px,py,pz,nx,ny,nz,X,Y,Z,{tl},C,E,was_colliding,singular,break,residual\n"
    );
    for (i, p) in w.iter().enumerate() {
        let a = &p.axes;
        let _ = writeln!(
            s,
            "{i},{},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{}",
            p.layer,
            p.p[0],
            p.p[1],
            p.p[2],
            p.n[0],
            p.n[1],
            p.n[2],
            a.xyz[0],
            a.xyz[1],
            a.xyz[2],
            a.tilt.to_degrees(),
            a.c.to_degrees(),
            p.e,
            p.was_colliding as u8,
            p.singular as u8,
            p.break_before as u8,
            p.residual as u8
        );
    }
    s
}

/// Read `[X, Y, Z, tilt°, C°]` per row of a plan CSV.
pub fn read_plan_axes(path: &Path) -> Result<Vec<[f64; 5]>, InputError> {
    let text = read_to_string(path)?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |names: &[&str]| header.iter().position(|h| names.contains(h));
    let idx: Vec<usize> = [&["X"][..], &["Y"], &["Z"], &["B", "A"], &["C"]]
        .iter()
        .map(|n| col(n))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| InputError::at(path, 1, "header needs columns X, Y, Z, B (or A) and C: give a plan.csv written by `maamplan plan`"))?;
    let mut out = Vec::new();
    for (i, l) in lines.enumerate() {
        if l.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = l.split(',').collect();
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
        out.push(v);
    }
    Ok(out)
}
