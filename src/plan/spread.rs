//! Spreading a rotation the extruder cannot follow over the neighbouring
//! waypoints.
//!
//! Near the vertical a small turn of the nozzle needs a large turn of C:
//! a ring printed with the nozzle tilted 8° outwards needs a full turn of C
//! per lap, and on short beads the table cannot keep up, so the extruder
//! dwells (tip speed below `v_min`). Letting C lag or lead its target a
//! little spreads the turn: C may differ from the waypoint's own by `δ_i`,
//! where turning C by `δ` at tilt `t` moves the nozzle by
//! `2 asin(sin|t| sin(δ/2))` — so a tolerance of a few degrees gives C a
//! wide tube near the vertical and a narrow one far from it. Within those
//! tubes, [`rate_limited`] finds C values that turn no faster than each
//! bead's time allows (`ω_C · L / v_min`), staying on the targets where
//! that is already so; the tilt is then spread the same way within what
//! the C spread left of the tolerance (an orientation moved by tilt and C
//! together moves by at most the sum). The results are offered to the graph
//! as extra candidates; the graph takes them where they are cheaper.

use super::cost::CostModel;
use crate::kinematics::Axes;

/// The C tube half-width (radians) that keeps the nozzle within `tol` of
/// its direction at tilt `tilt`: any C within `tol` of the vertical.
pub fn c_tube(tilt: f64, tol: f64) -> f64 {
    let s = tilt.sin().abs();
    let h = (0.5 * tol).sin();
    if s <= h {
        std::f64::consts::PI
    } else {
        2.0 * (h / s).asin()
    }
}

/// The angle between the nozzle directions of C and C + `dc` at `tilt`.
pub fn c_deviation(tilt: f64, dc: f64) -> f64 {
    2.0 * (tilt.sin().abs() * (0.5 * dc).sin().abs()).min(1.0).asin()
}

/// C values (unwound) within `tube[i]` of `target[i]` whose steps stay
/// within `rate[i]` (`rate[0]` unused) wherever the tubes allow: a forward
/// pass lagging behind fast turns, then a backward pass leading into them.
/// Where the tubes do not allow it, the value stays on the tube's edge
/// nearest the rate limit.
pub fn rate_limited(target: &[f64], tube: &[f64], rate: &[f64]) -> Vec<f64> {
    let n = target.len();
    let mut out = target.to_vec();
    let fit = |t: f64, w: f64, prev: f64, r: f64, own: f64| {
        let lo = (t - w).max(prev - r);
        let hi = (t + w).min(prev + r);
        if lo <= hi {
            own.clamp(lo, hi)
        } else if prev - r > t + w {
            t + w
        } else {
            t - w
        }
    };
    for i in 1..n {
        out[i] = fit(target[i], tube[i], out[i - 1], rate[i], target[i]);
    }
    for i in (0..n.saturating_sub(1)).rev() {
        out[i] = fit(target[i], tube[i], out[i + 1], rate[i + 1], out[i]);
    }
    out
}

/// How much shorter a piece of bead between two written (rounded)
/// positions can be than between the points it was planned between (mm):
/// 0.0005 mm on each linear axis and 0.0005° on each angle, at both ends,
/// 100 mm from the rotary axes.
const ROUNDING_MM: f64 = 0.004;

/// The spread of one printed run — configurations `cfg` in print order,
/// `bead_in[i]` the length of the bead into `cfg[i]` (the first's is
/// not printed: it enters the run through a break, or starts it), printed with `cm` — within `tol` radians of each orientation:
/// `(i, tilt, c)` for each configuration whose spread values differ from
/// its own, C unwound along the run. Empty when no bead of the run makes
/// the extruder dwell. `pieces(i, turn)`: how many lines the program
/// writes the bead into `cfg[i]` as when its orientation turns by `turn`
/// radians ([`crate::prove::bounds::pieces_bound`]).
pub fn spread_run(
    cfg: &[Axes],
    bead_in: &[f64],
    cm: &CostModel,
    tol: f64,
    pieces: impl Fn(usize, f64) -> usize,
) -> Vec<(usize, f64, f64)> {
    let n = cfg.len();
    let slow = (1..n).any(|i| cm.dwell(bead_in[i], &cfg[i - 1], &cfg[i]) > 0.0);
    if n < 2 || !slow {
        return Vec::new();
    }
    let mut target: Vec<f64> = Vec::with_capacity(n);
    for a in cfg {
        let prev = target.last().copied().unwrap_or(a.c);
        target.push(prev + cm.winding.dc(prev, a.c));
    }
    // Each bead's time at the slowest tip speed, less room for the
    // program's rounding: each line the bead is written as may be up to
    // ROUNDING_MM shorter, each angle 0.001° off. A line of a bead split
    // into short pieces must keep the speed on its own.
    let budget = |i: usize, speed: f64, lines: usize| {
        let len = (bead_in[i] - lines as f64 * ROUNDING_MM).max(0.0);
        ((speed * len / cm.tip_speed[0]) * (1.0 - 1e-3) - 0.002)
            .max(0.0)
            .to_radians()
    };
    // The lines of a bead turning as fast as one line allows (the spread
    // turns it no faster).
    let lines: Vec<usize> = (0..n)
        .map(|i| pieces(i, budget(i, cm.rotary[0], 1) + budget(i, cm.rotary[1], 1)).max(1))
        .collect();
    // C first, within the whole tolerance; then the tilt, within what C
    // left of it.
    let tube: Vec<f64> = cfg.iter().map(|a| c_tube(a.tilt, tol)).collect();
    let rate: Vec<f64> = (0..n).map(|i| budget(i, cm.rotary[1], lines[i])).collect();
    let c = rate_limited(&target, &tube, &rate);
    let tilts: Vec<f64> = cfg.iter().map(|a| a.tilt).collect();
    let t_tube: Vec<f64> = (0..n)
        .map(|i| (tol - c_deviation(cfg[i].tilt, c[i] - target[i])).max(0.0))
        .collect();
    let t_rate: Vec<f64> = (0..n).map(|i| budget(i, cm.rotary[0], lines[i])).collect();
    let t = rate_limited(&tilts, &t_tube, &t_rate);
    (0..n)
        .filter(|&i| (c[i] - target[i]).abs() > 1e-5 || (t[i] - tilts[i]).abs() > 1e-5)
        .map(|i| (i, t[i], c[i]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fast_ring_is_slowed_within_the_tube() {
        // A ring needing 13° of C per bead where 12° is the most the table
        // can turn: C lags, within the tube, and never turns too fast.
        let n = 60;
        let target: Vec<f64> = (0..n).map(|i| (13.0 * i as f64).to_radians()).collect();
        let tilt = 8f64.to_radians();
        let tube: Vec<f64> = vec![c_tube(tilt, 4.5f64.to_radians()); n];
        let rate: Vec<f64> = vec![12f64.to_radians(); n];
        let c = rate_limited(&target, &tube, &rate);
        for i in 1..n {
            assert!((c[i] - c[i - 1]).abs() <= rate[i] + 1e-12, "step {i}");
            assert!((c[i] - target[i]).abs() <= tube[i] + 1e-12);
            assert!(c_deviation(tilt, c[i] - target[i]) <= 4.5f64.to_radians() + 1e-9);
        }
        // Where the rate allows, the targets are kept.
        let slow: Vec<f64> = (0..n).map(|i| (5.0 * i as f64).to_radians()).collect();
        assert_eq!(rate_limited(&slow, &tube, &rate), slow);
    }

    /// A ring near the vertical whose C turns by 35° and 5° a bead in
    /// turn (20° on average, where 25° is the most a bead allows), each
    /// bead written as 14 lines: every line keeps the tip speed on its
    /// own, each up to `ROUNDING_MM` shorter as written (a room of one
    /// rounding per bead let the lines of a bead at the limit fall short).
    #[test]
    fn every_line_of_a_spread_bead_keeps_the_tip_speed() {
        use crate::kinematics::Machine;
        let m = Machine::default();
        let cm = CostModel::new(&m, m.feed, m.tip_speed, 10.0);
        let (n, len, lines) = (80, 1.85, 14);
        let cfg: Vec<Axes> = (0..n)
            .map(|i| {
                let c = (20.0 * i as f64 + if i % 2 == 1 { 15.0 } else { 0.0 }).to_radians();
                m.axes_at([20.0, 0.0, 40.0], (3f64.to_radians(), c))
            })
            .collect();
        let bead_in: Vec<f64> = (0..n).map(|i| if i > 0 { len } else { 0.0 }).collect();
        let out = spread_run(&cfg, &bead_in, &cm, 4.5f64.to_radians(), |_, _| lines);
        assert!(out.len() >= n / 4, "{} of {n} spread", out.len());
        let mut c: Vec<f64> = cfg.iter().map(|a| a.c).collect();
        let mut t: Vec<f64> = cfg.iter().map(|a| a.tilt).collect();
        for &(i, tilt, ci) in &out {
            (t[i], c[i]) = (tilt, ci);
        }
        let line = len / lines as f64 - ROUNDING_MM;
        for i in 1..n {
            for (turn, rate) in [
                ((c[i] - c[i - 1]).abs(), cm.rotary[1]),
                ((t[i] - t[i - 1]).abs(), cm.rotary[0]),
            ] {
                let seconds = turn.to_degrees() / lines as f64 / rate;
                assert!(
                    line / seconds >= cm.tip_speed[0],
                    "bead {i}: {} mm/s",
                    line / seconds
                );
            }
        }
    }

    #[test]
    fn far_from_the_vertical_the_tube_is_narrow() {
        let tol = 4.5f64.to_radians();
        assert!(c_tube(60f64.to_radians(), tol) < 6f64.to_radians());
        assert_eq!(c_tube(1f64.to_radians(), tol), std::f64::consts::PI);
        let t = 30f64.to_radians();
        assert!((c_deviation(t, c_tube(t, tol)) - tol).abs() < 1e-9);
    }
}
