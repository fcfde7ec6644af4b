//! Watching a program run, for `plan` and `simulate` alike: `program.glb`
//! and the problems' pictures made side by side, and a plan's written
//! program read back so its page and scene show what `simulate` would.

use super::html::Seen;
use super::machine_bodies::machine_bodies;
use super::plan_files::{RenderError, StageSink};
use super::playback::Playback;
use super::program_glb::{program_glb, ProgramScene};
use super::snapshot::{pictures, Pictures};
use crate::io::gcode_read::GcodeMove;
use crate::job::LoadedJob;
use crate::kinematics::Machine;
use crate::simulate::{replay, Simulation, Timeline};
use std::time::Instant;

/// `program.glb` and the pictures of `program`, made side by side (the
/// pictures checked at `margin`); a note for each to `show`, with its
/// size or count.
pub fn seen_side_by_side(
    program: &ProgramScene,
    margin: f64,
    show: &dyn StageSink,
) -> (Vec<u8>, Pictures) {
    let ((glb, glb_s), (pictures, pictures_s)) = rayon::join(
        || {
            let t = Instant::now();
            let glb = program_glb(program);
            (glb, t.elapsed().as_secs_f64())
        },
        || {
            let t = Instant::now();
            let p = pictures(program, margin as f32);
            (p, t.elapsed().as_secs_f64())
        },
    );
    show.note(&format!(
        "program.glb     {glb_s:>8.3} s {:>9.1} MB",
        glb.len() as f64 / 1e6
    ));
    show.note(&match &pictures.missing {
        None => format!(
            "pictures        {pictures_s:>8.3} s {:>12} on {}",
            pictures.problems.len() + 1,
            pictures.adapter
        ),
        Some(why) => format!("pictures: none ({why})"),
    });
    (glb, pictures)
}

/// A plan's written program read back as `simulate` reads it: its moves,
/// when material appears, and its problems at `margin`.
pub struct ReadBack {
    moves: Vec<GcodeMove>,
    timeline: Timeline,
    sim: Simulation,
    margin: f64,
}

/// Read back the written program `gcode` of a plan of `job` for `machine`,
/// its problems checked at `margin` ([`replay`]).
pub fn read_back(
    machine: &Machine,
    job: &LoadedJob,
    gcode: &str,
    margin: f64,
) -> Result<ReadBack, RenderError> {
    let (moves, timeline, sim) =
        replay(machine, &job.toolpath, gcode, margin).map_err(RenderError::ReadBack)?;
    Ok(ReadBack {
        moves,
        timeline,
        sim,
        margin,
    })
}

/// A plan's program, read back (`back`), watched: `program.glb`, and the
/// page `page` makes with the problems' times and pictures.
pub fn watched(
    machine: &Machine,
    job: &LoadedJob,
    back: &ReadBack,
    show: &dyn StageSink,
    page: impl FnOnce(&Seen) -> String,
) -> Result<(Vec<u8>, String), RenderError> {
    let playback = Playback::new(&back.moves, &back.sim, &back.timeline);
    let stamp = |s: u32| if s == 0 { 0 } else { back.timeline.stamp(s) };
    let program = ProgramScene {
        machine,
        scene: &job.scene,
        playback: &playback,
        stamp: &stamp,
        bodies: &machine_bodies(machine).map_err(RenderError::Bodies)?,
    };
    let (glb, pictures) = seen_side_by_side(&program, back.margin, show);
    let html = page(&Seen {
        playback: &playback,
        pictures: &pictures,
    });
    Ok((glb, html))
}
