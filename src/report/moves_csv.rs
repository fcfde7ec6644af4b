//! `moves.csv` of `simulate -o`: one row per line of the program that
//! moves, as [`crate::simulate`] measured it.

use crate::simulate::Simulation;
use std::fmt::Write;

/// The CSV text: every measured line of `sim`, in program order.
pub fn write_moves_csv(sim: &Simulation) -> String {
    let mut t = String::from(
        "line,extrudes,tcp,layer,seconds,length_mm,tip_speed,deviation_mm,rotary_step_deg,tilt_deg,c_deg,e_per_mm,collides\n",
    );
    for r in &sim.moves {
        let _ = writeln!(
            t,
            "{},{},{},{},{:.6},{:.4},{:.4},{:.4},{:.3},{:.3},{:.3},{:.5},{}",
            r.line,
            r.extrudes as u8,
            r.tcp as u8,
            r.layer.map_or(String::new(), |l| l.to_string()),
            r.seconds,
            r.length_mm,
            r.tip_speed,
            r.deviation_mm,
            r.rotary_step_deg,
            r.tilt_deg,
            r.c_deg,
            r.e_per_mm,
            r.collides as u8
        );
    }
    t
}
