//! What a long `plan` run shows while it works: on a terminal, a bar per
//! stage with the queries of the current batch, their rate and an ETA;
//! with `-v`, one line per stage (seconds, collision queries, the backend
//! calls that answered them and the seconds they took) as each
//! stage ends — on stdout, so the lines arrive as they happen when the
//! output goes to a pipe or a log.

use indicatif::{ProgressBar, ProgressStyle};
use maamplan::plan::Progress;
use std::time::Duration;

/// The progress display of one run.
pub struct Reporter {
    bar: ProgressBar,
    verbose: bool,
    counting: std::sync::atomic::AtomicBool,
}

impl Reporter {
    /// Bars unless `quiet` (and only where stderr is a terminal); stage
    /// lines when `verbose`.
    pub fn new(quiet: bool, verbose: bool) -> Self {
        let bar = if quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::new_spinner()
        };
        bar.set_style(spinner_style());
        bar.enable_steady_tick(Duration::from_millis(120));
        Reporter {
            bar,
            verbose: verbose && !quiet,
            counting: false.into(),
        }
    }

    /// A stage that ran outside the planner (load, write, report).
    pub fn stage_line(&self, name: &str, seconds: f64, queries: Option<u64>) {
        if !self.verbose {
            return;
        }
        self.note(&stage_text(name, seconds, queries));
    }

    /// A planner's stage under `-v`: the [`Reporter::stage_line`], then
    /// the backend calls that answered its queries and their wall time,
    /// the evaluator's share of the stage.
    fn planner_stage_line(&self, s: &maamplan::plan::Stage) {
        if !self.verbose {
            return;
        }
        let a = s.answering;
        let mut line = stage_text(&s.name, s.seconds, Some(s.queries));
        if a.calls > 0 {
            line += &format!(" in {} calls, {:.3} s answering", a.calls, a.seconds);
        }
        if a.beside > 0 {
            line += &format!(" ({} beside in {:.3} s)", a.beside, a.beside_seconds);
        }
        self.note(&line);
    }

    /// A line of detail under `-v` (where the head's data came from).
    pub fn note(&self, line: &str) {
        if !self.verbose {
            return;
        }
        if self.bar.is_hidden() {
            println!("{line}");
        } else {
            self.bar.println(line);
        }
    }

    /// Show a stage that begins outside the planner.
    pub fn begin(&self, what: &str) {
        use std::sync::atomic::Ordering;
        self.counting.store(false, Ordering::Relaxed);
        self.bar.set_style(spinner_style());
        self.bar.set_message(what.to_string());
    }

    /// The planner's events.
    pub fn on(&self, p: Progress) {
        use std::sync::atomic::Ordering;
        match p {
            Progress::Stage(name) => self.begin(name.as_str()),
            Progress::Queries { done, total } => {
                if !self.counting.swap(true, Ordering::Relaxed) {
                    self.bar.set_style(bar_style());
                }
                self.bar.set_length(total);
                if done < self.bar.position() || done == 0 {
                    self.bar.reset_eta();
                }
                self.bar.set_position(done);
            }
            Progress::Done(s) => self.planner_stage_line(s),
        }
    }

    /// Clear the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// A stage's `-v` line: its name, seconds and collision queries, if any.
fn stage_text(name: &str, seconds: f64, queries: Option<u64>) -> String {
    match queries {
        Some(q) => format!("stage {name:<14} {seconds:>8.3} s {q:>12} collision queries"),
        None => format!("stage {name:<14} {seconds:>8.3} s"),
    }
}

impl maamplan::report::plan_files::StageSink for Reporter {
    fn begin(&self, what: &str) {
        Reporter::begin(self, what);
    }
    fn stage_line(&self, name: &str, seconds: f64, queries: Option<u64>) {
        Reporter::stage_line(self, name, seconds, queries);
    }
    fn note(&self, line: &str) {
        Reporter::note(self, line);
    }
}

impl Drop for Reporter {
    /// An error ends the run with the bar cleared, not frozen.
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

fn spinner_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("static template")
}

fn bar_style() -> ProgressStyle {
    ProgressStyle::with_template(
        "{spinner} {msg} [{bar:30}] {human_pos}/{human_len} queries, {per_sec}, ETA {eta} ({elapsed})",
    )
    .expect("static template")
}
