//! What `plan` writes, rendered in memory and written at once: the
//! program, the CSV, report.json and (unless plots are off) the scenes,
//! the page and the plots. The command line and the Python binding's
//! `Plan.write` both write a plan's outputs through this.

use crate::io::gcode::{write_gcode, GcodeHeader};
use crate::io::output::{write_output_set, FolderFile};
use crate::io::plan_csv::write_plan_csv;
use crate::job::LoadedJob;
use crate::kinematics::Machine;
use crate::plan::Plan;
use crate::report::html::{report_html, ReportContext};
use crate::report::plots::figure_files;
use crate::report::scene_glb::scene_glb;
use crate::report::watch::{read_back, watched};
use std::path::Path;
use std::time::Instant;

/// Where rendering tells its stages as they begin and end: the command
/// line's progress display, or nobody (`()`).
pub trait StageSink: Sync {
    /// A stage begins.
    fn begin(&self, what: &str);
    /// A stage ended after `seconds` (and `queries` collision queries).
    fn stage_line(&self, name: &str, seconds: f64, queries: Option<u64>);
    /// A line of detail (the command line shows it under `-v`).
    fn note(&self, _line: &str) {}
}

impl StageSink for () {
    fn begin(&self, _: &str) {}
    fn stage_line(&self, _: &str, _: f64, _: Option<u64>) {}
}

/// The plots could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("drawing the plots: {0}")]
pub struct PlotError(pub String);

/// What can stop a plan's outputs being rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The plots.
    #[error(transparent)]
    Plots(#[from] PlotError),
    /// The written program did not read back (an internal error).
    #[error("reading the written program back: {0}")]
    ReadBack(#[source] crate::io::gcode_read::GcodeError),
    /// A body the machine file names to draw.
    #[error("{0}")]
    Bodies(#[source] crate::io::InputError),
}

/// The output folder cannot be made or written (the user can fix that:
/// another folder).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct OutputError(pub String);

/// What `plan` writes besides report.json, rendered in memory: the
/// program and the CSV, and unless `--no-plots` the report's files.
pub struct Rendered {
    gcode: String,
    csv: String,
    report: Option<ReportFiles>,
    /// Seconds of the `write` stage (the program and the CSV) and of the
    /// `report` stage.
    pub stages: Vec<(String, f64)>,
}

/// The scenes, the page and the plots folder.
struct ReportFiles {
    glb: Vec<u8>,
    program_glb: Vec<u8>,
    html: String,
    plots: Vec<FolderFile>,
}

impl Rendered {
    /// Render the outputs of plan `p`: the program, written and read back
    /// ([`read_back`]), side by side with the CSV, the figures and the
    /// scene; the program is then watched ([`watched`]). `report_margin`:
    /// the margin the report's pictures check at, `None` for no report.
    pub fn new(
        machine: &Machine,
        p: &Plan,
        job: &LoadedJob,
        context: &ReportContext,
        seconds: f64,
        report_margin: Option<f64>,
        show: &dyn StageSink,
    ) -> Result<Self, RenderError> {
        // What the planner freed, handed back before the outputs are made.
        crate::plan::memory::release_all_freed_memory();
        let header = GcodeHeader {
            source: job.source.clone(),
            command: context.command.to_string(),
        };
        // The program is read back as soon as it is written, beside the
        // CSV, the figures and the scene, which fill the cores the read
        // back's serial steps leave idle.
        let started = Instant::now();
        let ((gcode, gcode_s, back), (csv, drawn)) = rayon::join(
            || {
                let gcode = write_gcode(machine, &p.program, &header);
                let gcode_s = started.elapsed().as_secs_f64();
                let back = report_margin.map(|margin| read_back(machine, job, &gcode, margin));
                (gcode, gcode_s, back)
            },
            || {
                rayon::join(
                    || {
                        let csv = write_plan_csv(machine, &p.waypoints);
                        (csv, started.elapsed().as_secs_f64())
                    },
                    || {
                        report_margin.map(|_| {
                            rayon::join(
                                || figure_files(machine, p),
                                || scene_glb(&job.scene, p, machine),
                            )
                        })
                    },
                )
            },
        );
        let (csv, csv_s) = csv;
        let write_s = gcode_s.max(csv_s);
        show.stage_line("write", write_s, None);
        let mut stages = vec![("write".to_string(), write_s)];
        let report = match (drawn, back) {
            (Some((figures, glb)), Some(back)) => {
                show.begin("report");
                let back = back?;
                let (figures, plots) = figures.map_err(PlotError)?;
                let (program_glb, html) = watched(machine, job, &back, show, |seen| {
                    report_html(context, machine, p, &figures, seconds, Some(seen))
                })?;
                let report_s = started.elapsed().as_secs_f64();
                show.stage_line("report", report_s, None);
                stages.push(("report".to_string(), report_s));
                Some(ReportFiles {
                    glb,
                    program_glb,
                    html,
                    plots,
                })
            }
            _ => None,
        };
        Ok(Rendered {
            gcode,
            csv,
            report,
            stages,
        })
    }

    /// The output folder's files, report.json's `report_json` among them,
    /// in the order they are listed to the user.
    pub fn into_files(self, report_json: Vec<u8>) -> Vec<FolderFile> {
        let mut files = vec![
            ("toolpath.gcode".into(), self.gcode.into_bytes()),
            ("plan.csv".into(), self.csv.into_bytes()),
            ("report.json".into(), report_json),
        ];
        if let Some(r) = self.report {
            files.push(("scene.glb".into(), r.glb));
            files.push(("program.glb".into(), r.program_glb));
            files.push(("report.html".into(), r.html.into_bytes()));
            files.extend(r.plots);
        }
        files
    }
}

/// Everything `plan` may write into its output folder: a run replaces
/// all of it, so no earlier run's report or plots stay beside a new
/// program.
pub const PLAN_OUTPUTS: [&str; 7] = [
    "toolpath.gcode",
    "plan.csv",
    "report.json",
    "scene.glb",
    "program.glb",
    "report.html",
    "plots",
];

/// Write `files` into the output folder `out` at once: a failed run
/// leaves nothing, and no output of an earlier run stays
/// ([`write_output_set`]).
pub fn write_output(out: &Path, files: &[FolderFile]) -> Result<(), OutputError> {
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(|e| {
        OutputError(format!(
            "{}: cannot create the output folder ({e})",
            parent.display()
        ))
    })?;
    write_output_set(out, files, &PLAN_OUTPUTS)
        .map_err(|e| OutputError(format!("{}: cannot write ({e})", out.display())))?;
    Ok(())
}
