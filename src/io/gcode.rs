//! G-code in the dialect of the data set's reference output
//! (`reference_gcode/simple_curve_Gcode.txt`): absolute moves, `G1 X Y Z B C
//! E` per waypoint with three decimals, E reset per layer with `G92 E0`,
//! and retract / lift 50 mm above everything so far / travel / approach /
//! prime between layers and at breaks. A/C machines write `A` for the tilt.

use crate::kinematics::{Machine, Rotary};
use crate::plan::PlannedWaypoint;
use std::fmt::Write;

const Z_HOME: f64 = 230.0;
const Z_LIFT: f64 = 50.0;
const Z_APPROACH: f64 = 2.0;

/// The whole program for `waypoints` (print order).
pub fn write_gcode(m: &Machine, waypoints: &[PlannedWaypoint]) -> String {
    let tl = if m.rotary == Rotary::AC { 'A' } else { 'B' };
    let t = m.extrusion.temperature;
    let mut g = String::with_capacity(waypoints.len() * 64 + 1024);
    let deg = |r: f64| r.to_degrees();
    let _ = writeln!(
        g,
        "G90\nM104 S{t} T1\nG28 X0.000 Y0.000 Z230.000 {tl}0.000 C0.000 F5250\nM109 S{t} T1"
    );
    let mut z_run = f64::NEG_INFINITY;
    for (i, w) in waypoints.iter().enumerate() {
        let a = &w.axes;
        let [x, y, z] = a.xyz;
        let travel = format!(
            "G0 X{x:.3} Y{y:.3} {tl}{:.3} C{:.3} F5250",
            deg(a.tilt),
            deg(a.c)
        );
        let new_layer = i == 0 || waypoints[i - 1].layer != w.layer;
        if i == 0 {
            // First layer: approach above its highest point, prime.
            let zmax = waypoints
                .iter()
                .take_while(|v| v.layer == w.layer)
                .map(|v| v.axes.xyz[2])
                .fold(z, f64::max);
            let _ = writeln!(
                g,
                "{travel}\nG0 Z{:.3} F4750\nG92 E0\nG1 E12.000 F4550\nG92 E0\nG1 F1500",
                zmax + Z_APPROACH
            );
        } else if new_layer {
            z_run = z_run.max(z);
            let _ = writeln!(
                g,
                "G92 E0\nG0 E-6.000 F4800\nG92 E0\nG0 Z{:.3} F4750\n{travel}\nG0 Z{:.3} F4750\nG1 E9.000 F4550\nG92 E0\nG1 F1500",
                z_run + Z_LIFT,
                z + Z_APPROACH
            );
        } else if w.section_start || w.break_before {
            z_run = z_run.max(z);
            let _ = writeln!(
                g,
                "G0 E{:.3} F4800\nG0 Z{:.3} F4750\n{travel}\nG0 Z{:.3} F4750\nG0 E{:.3} F4550\nG0 Z{z:.3} E{:.3} F1500",
                w.e - 5.7,
                z_run + Z_LIFT,
                z + Z_APPROACH,
                w.e - 0.1,
                w.e
            );
        }
        z_run = z_run.max(z);
        let _ = writeln!(
            g,
            "G1 X{x:.3} Y{y:.3} Z{z:.3} {tl}{:.3} C{:.3} E{:.3}",
            deg(a.tilt),
            deg(a.c),
            w.e
        );
    }
    let _ = writeln!(
        g,
        "G92 E0\nG0 E-6.000 F5250\nG0 Z{Z_HOME:.3} F4750\nG0 X0 Y0 {tl}0 C0 F5250\nM30"
    );
    g
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
/// (degrees) between consecutive `G1 X` lines of a layer (layers start at
/// `G92 E0` followed by a travel).
pub fn rotary_motion(text: &str) -> (f64, f64) {
    let mut total = 0.0;
    let mut max_step: f64 = 0.0;
    let mut prev: Option<[f64; 2]> = None;
    for l in text.lines() {
        if l.starts_with("G0 X") {
            prev = None; // A travel: the next layer or section starts.
        } else if l.starts_with("G1 X") {
            let v = parse_g1(l)[0];
            if let Some(p) = prev {
                let s = (v[3] - p[0]).abs() + (v[4] - p[1]).abs();
                total += s;
                max_step = max_step.max(s);
            }
            prev = Some([v[3], v[4]]);
        }
    }
    (total, max_step)
}
