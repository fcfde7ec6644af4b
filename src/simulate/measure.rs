//! What each line of a program does, measured as `plan` measures its own
//! program ([`crate::plan::metrics`]), and the problems a process engineer
//! must hear about before the program runs.
//!
//! Per motion line with part-frame chord `L` between its tips: the
//! duration `t = max(t_feed, |ΔX|/vX, |ΔY|/vY, |ΔZ|/vZ, |Δtilt|/ω_tilt,
//! |ΔC|/ω_C)` with `t_feed = L / F` under `G94` (0 for `G0`: rapids go as
//! fast as the axes), `1 / F` minutes under `G93`, plus a dwell's wait
//! (`G4`: a line of its own); the tip speed `L / t`; the tip's largest
//! distance from the chord as the controller interpolates (0 under tool-centre-point control); the rotary step
//! `|Δtilt| + |ΔC|`; the filament per millimetre of bead.

use crate::io::gcode_read::{axes_of, GcodeMove};
use crate::kinematics::{Axes, Machine};
use crate::plan::metrics::tip_deviation;
use crate::prove::tip_deviation_bound;
use serde::Serialize;

/// How [`measure`] finds an extruding line's tip deviation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Deviation {
    /// Sampled on every line, as a controller interpolates
    /// ([`tip_deviation`]): what `simulate` reports line by line.
    Sampled,
    /// Sampled only where the bow's analytic bound
    /// ([`tip_deviation_bound`]) reaches the machine's tip tolerance; the
    /// bound stands in for the others. The tip-deviation problems are
    /// the sampled ones (no line under its bound can pass the tolerance)
    /// at a fraction of the work: a planned program splits its beads
    /// until their bounds keep the tolerance, so none is sampled.
    OverTolerance,
}

/// Rotary motion while extruding above which a line is reported as a
/// swing (degrees): the extruder keeps feeding while the part turns that
/// far under a short bead.
pub const SWING_DEG: f64 = 45.0;

/// Relative tolerance of the tip-speed range: a program writes its numbers
/// to a few decimals (a `G93` feed to seven significant digits), so a line
/// planned at exactly `v_max` reads back a few parts in ten million off.
pub const SPEED_TOLERANCE: f64 = 1e-5;

/// Is `v` outside `[lo, hi]` by more than [`SPEED_TOLERANCE`]?
pub fn outside_range(v: f64, [lo, hi]: [f64; 2]) -> bool {
    v < lo * (1.0 - SPEED_TOLERANCE) || v > hi * (1.0 + SPEED_TOLERANCE)
}

/// Filament per millimetre above this multiple of the program's median is
/// reported as a blob.
pub const BLOB_FACTOR: f64 = 3.0;

/// One motion line, measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MoveReport {
    /// 1-based G-code line.
    pub line: usize,
    /// Extrudes while moving.
    pub extrudes: bool,
    /// Interpolated under tool-centre-point control.
    pub tcp: bool,
    /// Layer the line reads as.
    pub layer: Option<usize>,
    /// Seconds.
    pub seconds: f64,
    /// Part-frame chord between the tips (mm).
    pub length_mm: f64,
    /// Tip speed over the part (mm/s).
    pub tip_speed: f64,
    /// Largest distance of the tip from the chord (mm).
    pub deviation_mm: f64,
    /// |Δtilt| + |ΔC| (degrees).
    pub rotary_step_deg: f64,
    /// Tilt axis at the end of the line (degrees, the planner's sign).
    pub tilt_deg: f64,
    /// C at the end of the line (degrees, the planner's sign).
    pub c_deg: f64,
    /// Filament per mm of bead (extruding lines).
    pub e_per_mm: f64,
    /// Comes within the margin of the platform or printed material.
    pub collides: bool,
}

/// Measure `mv` on `m` (whose dialect says how the line interpolates),
/// its tip deviation as `deviation` says.
pub fn measure(m: &Machine, mv: &GcodeMove, deviation: Deviation) -> MoveReport {
    let (a, b) = (axes_of(&mv.from), axes_of(&mv.to));
    let (pa, pb) = (m.tip(&a), m.tip(&b));
    let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]).hypot(pb[2] - pa[2]);
    let d: [f64; 5] = std::array::from_fn(|k| (mv.to[k] - mv.from[k]).abs());
    let commanded = if !mv.moves_axes() && mv.de == 0.0 {
        0.0
    } else if mv.inverse_time {
        60.0 / mv.f
    } else if !mv.moves_axes() {
        mv.de.abs() / (mv.f / 60.0)
    } else if mv.linear {
        len / (mv.f / 60.0)
    } else {
        0.0
    };
    let seconds = [
        commanded,
        d[0] / m.x.speed,
        d[1] / m.y.speed,
        d[2] / m.z.speed,
        d[3] / m.tilt.speed,
        d[4] / m.c.speed,
    ]
    .into_iter()
    .fold(0.0, f64::max);
    let extrudes = mv.extrudes();
    let moving = seconds;
    // A dwell's wait is the program's time too (a line is one or the other).
    let seconds = seconds + mv.dwell;
    MoveReport {
        line: mv.line,
        extrudes,
        tcp: mv.tcp,
        layer: None,
        seconds,
        length_mm: len,
        tip_speed: if moving > 0.0 { len / moving } else { 0.0 },
        deviation_mm: if extrudes {
            deviation_of(m, &a, &b, deviation)
        } else {
            0.0
        },
        rotary_step_deg: d[3] + d[4],
        tilt_deg: mv.to[3],
        c_deg: mv.to[4],
        e_per_mm: if extrudes && len > 0.0 {
            mv.de / len
        } else {
            0.0
        },
        collides: false,
    }
}

/// The tip deviation of the extruding line `a → b` as `how` finds it.
fn deviation_of(m: &Machine, a: &Axes, b: &Axes, how: Deviation) -> f64 {
    if how == Deviation::OverTolerance {
        // (0 under tool-centre-point control, as the sampling.)
        let bound = tip_deviation_bound(m, a, b);
        // (A line within rounding of the tolerance is sampled.)
        if bound < m.tip_tolerance * (1.0 - 1e-9) {
            return bound;
        }
    }
    tip_deviation(m, a, b)
}

/// What is wrong with one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum ProblemKind {
    /// The head comes within the margin of the platform or printed material.
    Collision,
    /// The tip leaves the bead by more than the machine's tip tolerance.
    TipDeviation,
    /// The tip speed leaves the extruder's range.
    TipSpeed,
    /// The part turns more than [`SWING_DEG`] under one extruding line.
    Swing,
    /// Filament per mm above [`BLOB_FACTOR`] × the program's median.
    Blob,
    /// A travel turns C by more than half a turn (the other way is shorter).
    LongTravelTurn,
}

impl ProblemKind {
    /// Every kind, in the order reports list them.
    pub const ALL: [ProblemKind; 6] = [
        ProblemKind::Collision,
        ProblemKind::TipDeviation,
        ProblemKind::TipSpeed,
        ProblemKind::Swing,
        ProblemKind::Blob,
        ProblemKind::LongTravelTurn,
    ];
}

/// One problem, at its G-code line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Problem {
    /// 1-based G-code line.
    pub line: usize,
    /// What.
    pub kind: ProblemKind,
    /// The measured value (mm, mm/s, degrees, filament per mm; 0 for collisions).
    pub value: f64,
    /// Layer the line reads as.
    pub layer: Option<usize>,
}

/// The travels of a program: maximal runs of lines that do not extrude
/// between extruding ones, as `(index of the first line in moves, total
/// |ΔC| in degrees)`.
pub fn travels(moves: &[GcodeMove]) -> Vec<(usize, f64)> {
    let mut out = Vec::new();
    let mut cur: Option<(usize, f64)> = None;
    for (i, mv) in moves.iter().enumerate().filter(|(_, mv)| mv.moves_axes()) {
        if mv.extrudes() {
            if let Some(c) = cur.take() {
                out.push(c);
            }
        } else {
            let c = cur.get_or_insert((i, 0.0));
            c.1 += (mv.to[4] - mv.from[4]).abs();
        }
    }
    out.extend(cur);
    out
}

/// The tip-speed range of the extruder `tool`.
pub fn tip_range(m: &Machine, tool: u32) -> [f64; 2] {
    if tool == m.support.tool && tool != m.extrusion.tool {
        m.support.tip_speed
    } else {
        m.tip_speed
    }
}

/// Every problem of the measured lines `reports` (one per line of `moves`), in line order.
pub fn problems(m: &Machine, moves: &[GcodeMove], reports: &[MoveReport]) -> Vec<Problem> {
    let mut out = Vec::new();
    let median = median(
        reports
            .iter()
            .filter(|r| r.extrudes && r.length_mm > 0.0)
            .map(|r| r.e_per_mm),
    );
    for (mv, r) in moves.iter().zip(reports) {
        let mut push = |kind, value| {
            out.push(Problem {
                line: r.line,
                kind,
                value,
                layer: r.layer,
            })
        };
        if r.collides {
            push(ProblemKind::Collision, 0.0);
        }
        if !r.extrudes {
            continue;
        }
        if r.deviation_mm > m.tip_tolerance {
            push(ProblemKind::TipDeviation, r.deviation_mm);
        }
        if outside_range(r.tip_speed, tip_range(m, mv.tool)) {
            push(ProblemKind::TipSpeed, r.tip_speed);
        }
        if r.rotary_step_deg > SWING_DEG {
            push(ProblemKind::Swing, r.rotary_step_deg);
        }
        if median > 0.0 && r.e_per_mm > BLOB_FACTOR * median {
            push(ProblemKind::Blob, r.e_per_mm);
        }
    }
    for (i, c) in travels(moves) {
        if c > 180.0 + 1e-6 {
            out.push(Problem {
                line: reports[i].line,
                kind: ProblemKind::LongTravelTurn,
                value: c,
                layer: reports[i].layer,
            });
        }
    }
    out.sort_by_key(|a| (a.line, a.kind));
    out
}

/// The median of `v` (0 when empty).
pub fn median(v: impl Iterator<Item = f64>) -> f64 {
    quantile(v.collect(), 0.5)
}

/// The `q` quantile of `v` (nearest rank; 0 when empty).
pub fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::xorshift;

    /// Extruding lines of every size, from short beads turning a little
    /// to long ones turning far.
    fn lines() -> Vec<GcodeMove> {
        let mut u = xorshift(0x00de_71a7_10e5_0001);
        (0..4000)
            .map(|k| {
                let scale = [0.01, 0.1, 1.0, 10.0][k % 4];
                let from = [
                    60.0 * u() - 30.0,
                    60.0 * u() - 30.0,
                    40.0 * u(),
                    90.0 * u(),
                    360.0 * u() - 180.0,
                ];
                let to: [f64; 5] = std::array::from_fn(|i| {
                    from[i] + scale * (2.0 * u() - 1.0) * [1.0, 1.0, 1.0, 5.0, 20.0][i]
                });
                GcodeMove {
                    line: k + 1,
                    linear: true,
                    from,
                    to,
                    e: 0.0,
                    de: 0.1,
                    f: 1200.0,
                    inverse_time: false,
                    tcp: false,
                    tool: 0,
                    dwell: 0.0,
                }
            })
            .collect()
    }

    /// Sampling only where the bound reaches the tolerance finds every
    /// line the full sampling finds over it, with its value, and never
    /// says less than the sampling of any line; many lines are left
    /// unsampled.
    #[test]
    fn deviations_over_the_tolerance_are_the_sampled_ones() {
        let m = Machine::default();
        let (mut over, mut under) = (0, 0);
        for mv in lines() {
            let every = measure(&m, &mv, Deviation::Sampled).deviation_mm;
            let some = measure(&m, &mv, Deviation::OverTolerance).deviation_mm;
            assert!(some >= every, "line {}: {some} < sampled {every}", mv.line);
            assert_eq!(
                every > m.tip_tolerance,
                some > m.tip_tolerance,
                "line {}",
                mv.line
            );
            if every > m.tip_tolerance {
                assert_eq!(some, every, "line {}", mv.line);
                over += 1;
            } else if some != every {
                under += 1;
            }
        }
        assert!(
            over > 200 && under > 1000,
            "{over} over, {under} left unsampled"
        );
    }
}
