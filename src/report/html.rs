//! `report.html`: one self-contained page (plots inline as SVG, no
//! network): the input-vs-plan summary, the per-layer table, the plots, the
//! machine and the command that produced it.

use super::plots::Figure;
use super::{layer_table, summary_rows};
use crate::kinematics::Machine;
use crate::plan::Plan;
use std::fmt::Write;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// What the page says about the run besides the plan.
pub struct ReportContext<'a> {
    /// The toolpath planned.
    pub source: &'a str,
    /// The command line.
    pub command: &'a str,
    /// Names of the layers whose nozzle directions were reversed on loading.
    pub flipped_layers: &'a [String],
}

/// The page.
pub fn report_html(
    ctx: &ReportContext,
    m: &Machine,
    plan: &Plan,
    figures: &[Figure],
    seconds: f64,
) -> String {
    let (source, command) = (ctx.source, ctx.command);
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>maamplan report — {}</title>\n<style>\
body{{font-family:sans-serif;margin:2em;color:#222;max-width:1000px}}table{{border-collapse:collapse;margin:1em 0}}\
td,th{{border:1px solid #ccc;padding:4px 10px;text-align:right}}th{{background:#f0f0f0}}td:first-child,th:first-child{{text-align:left}}\
figure{{margin:1.5em 0}}figcaption{{font-weight:bold}}pre{{background:#f7f7f7;padding:1em;overflow:auto}}</style></head><body>\n",
        esc(source)
    );
    let _ = writeln!(h, "<h1>Motion plan: {}</h1>", esc(source));
    let _ = writeln!(
        h,
        "<p>{} waypoints planned in {seconds:.2} s.</p>",
        plan.plan.waypoints
    );
    if !ctx.flipped_layers.is_empty() {
        let _ = writeln!(
            h,
            "<p id=\"flipped\">Nozzle directions reversed on loading (more than 20 % pointed down, as the data set's original software reads them): layers {}.</p>",
            esc(&ctx.flipped_layers.join(", "))
        );
    }
    if !plan.warnings.is_empty() {
        let _ = writeln!(h, "<h2>Warnings</h2><ul id=\"warnings\">");
        for w in plan.warnings.iter().take(200) {
            let _ = writeln!(h, "<li>{}</li>", esc(w));
        }
        if plan.warnings.len() > 200 {
            let _ = writeln!(
                h,
                "<li>… {} more in report.json</li>",
                plan.warnings.len() - 200
            );
        }
        let _ = writeln!(h, "</ul>");
    }
    let _ = writeln!(
        h,
        "<h2>Summary</h2><table id=\"summary\"><tr><th></th><th>input</th><th>plan</th></tr>"
    );
    for (k, a, b) in summary_rows(&plan.input, &plan.plan) {
        let _ = writeln!(h, "<tr><td>{k}</td><td>{a}</td><td>{b}</td></tr>");
    }
    let _ = writeln!(h, "</table>");
    let _ = writeln!(h, "<h2>Per layer</h2><table id=\"layers\"><tr><th>layer</th><th>waypoints</th><th>colliding (input)</th><th>skipped (plan)</th></tr>");
    for (k, (n, ci, cp)) in layer_table(plan).iter().enumerate() {
        let _ = writeln!(
            h,
            "<tr><td>{k}</td><td>{n}</td><td>{ci}</td><td>{cp}</td></tr>"
        );
    }
    let _ = writeln!(h, "</table>\n<h2>Plots</h2>");
    for f in figures {
        // The SVG documents go in as they are; drop their XML prolog.
        let svg = f.svg.trim_start_matches(|c| c != '<');
        let svg = if svg.starts_with("<?xml") {
            &svg[svg.find("?>").map_or(0, |i| i + 2)..]
        } else {
            svg
        };
        let _ = writeln!(
            h,
            "<figure id=\"{}\"><figcaption>{}</figcaption>{}</figure>",
            f.name,
            esc(&f.title),
            svg
        );
    }
    let _ = writeln!(h, "<h2>Machine</h2><pre>{}</pre>", esc(&m.to_toml()));
    let _ = writeln!(
        h,
        "<h2>Command</h2><pre>{}</pre>\n</body></html>",
        esc(command)
    );
    h
}
