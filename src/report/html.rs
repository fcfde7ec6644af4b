//! `report.html`: one self-contained page (plots inline as SVG, no
//! network): the input-vs-plan summary, the per-layer table, the plots, the
//! machine and the command that produced it.

use super::playback::Playback;
use super::plots::Figure;
use super::program_glb::kind_name;
use super::snapshot::Pictures;
use super::{layer_table, summary_rows};
use crate::kinematics::Machine;
use crate::plan::Plan;
use crate::scene::PartSource;
use crate::simulate::{Problem, ProblemKind, Simulation};
use std::fmt::Write;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The pages' style sheet.
const STYLE: &str = "body{font-family:sans-serif;margin:2em;color:#222;max-width:1000px}table{border-collapse:collapse;margin:1em 0}\
td,th{border:1px solid #ccc;padding:4px 10px;text-align:right}th{background:#f0f0f0}td:first-child,th:first-child{text-align:left}\
figure{margin:1.5em 0}img{max-width:100%;border:1px solid #ddd}figcaption{font-weight:bold}pre{background:#f7f7f7;padding:1em;overflow:auto}";

/// What the page says about the run besides the plan.
pub struct ReportContext<'a> {
    /// The toolpath planned.
    pub source: &'a str,
    /// What the part printed so far was modelled from.
    pub part: PartSource,
    /// The command line.
    pub command: &'a str,
    /// Names of the layers whose nozzle directions were reversed on loading.
    pub flipped_layers: &'a [String],
}

/// Per-layer B/C figures the page embeds at most (the plots folder has
/// them all): enough to see the part's story, small enough that the page
/// stays a few megabytes on parts of hundreds of layers.
pub const REPORT_LAYER_FIGURES: usize = 24;

/// At most `max` of `layers` layers, evenly spaced, first and last included.
pub fn shown_layers(layers: usize, max: usize) -> Vec<usize> {
    if layers <= max {
        return (0..layers).collect();
    }
    if max < 2 {
        return (0..max).collect();
    }
    let mut v: Vec<usize> = (0..max)
        .map(|i| (i * (layers - 1) + (max - 1) / 2) / (max - 1))
        .collect();
    v.dedup();
    v
}

/// The page; with `seen`, the written program's problems, their times
/// in program.glb and the pictures.
pub fn report_html(
    ctx: &ReportContext,
    m: &Machine,
    plan: &Plan,
    figures: &[Figure],
    seconds: f64,
    seen: Option<&Seen>,
) -> String {
    let mut h = page_start("report", "Motion plan", ctx);
    let _ = writeln!(
        h,
        "<p>{} waypoints planned in {seconds:.2} s.</p>",
        plan.plan.waypoints
    );
    if !ctx.flipped_layers.is_empty() {
        let _ = writeln!(
            h,
            "<p id=\"flipped\">Nozzle directions reversed on loading (in a layer more than 20 % pointed down, as the data set's original software reads them; in a toolpath given without layers, each that pointed into the material below): layers {}.</p>",
            esc(&ctx.flipped_layers.join(", "))
        );
    }
    warnings_section(&mut h, &super::warnings(ctx.part, &plan.warnings));
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
    let _ = writeln!(h, "</table>");
    if let Some(seen) = seen {
        pictures_section(&mut h, seen.pictures);
        problems_table(&mut h, seen.playback.problems, Some(seen.playback));
    }
    plots_section(
        &mut h,
        figures,
        "every layer's plot is in plots/bc_layer_&lt;k&gt;.svg and the full data in plan.csv",
    );
    page_end(h, m, ctx.command)
}

/// What the page shows of a program running: each problem's time in
/// `program.glb` and the pictures.
pub struct Seen<'a> {
    /// The program's timing.
    pub playback: &'a Playback<'a>,
    /// The pictures.
    pub pictures: &'a Pictures,
}

/// The page of a simulation: its numbers, its problems at their lines
/// (with `seen`, their times in program.glb and pictures), the plots, the
/// machine and the command.
pub fn simulation_html(
    ctx: &ReportContext,
    m: &Machine,
    sim: &Simulation,
    figures: &[Figure],
    seen: Option<&Seen>,
) -> String {
    let mut h = page_start("simulation", "Simulation", ctx);
    warnings_section(&mut h, &super::warnings(ctx.part, &[]));
    let _ = writeln!(h, "<h2>Summary</h2><table id=\"summary\">");
    let summary = serde_json::to_value(&sim.summary).unwrap_or_default();
    if let Some(obj) = summary.as_object() {
        for (k, v) in obj {
            let v = match v.as_f64() {
                Some(x) if v.is_f64() => format!("{x:.4}"),
                _ => v.to_string(),
            };
            let _ = writeln!(h, "<tr><td>{}</td><td>{v}</td></tr>", esc(k));
        }
    }
    let _ = writeln!(h, "</table>");
    if let Some(seen) = seen {
        pictures_section(&mut h, seen.pictures);
    }
    problems_table(&mut h, &sim.problems, seen.map(|s| s.playback));
    plots_section(&mut h, figures, "every line's axes are in moves.csv");
    page_end(h, m, ctx.command)
}

/// Every problem (the first 500) with its line, value, layer and, with
/// `playback`, the time in program.glb at which its line ends.
fn problems_table(h: &mut String, problems: &[Problem], playback: Option<&Playback>) {
    let _ = writeln!(
        h,
        "<h2>Problems</h2><p>{} in all{}.</p><table id=\"problems\"><tr><th>line</th><th>problem</th><th>value</th><th>layer</th><th>time in program.glb (s)</th></tr>",
        problems.len(),
        if problems.len() > 500 { "; the first 500 here, every one in report.json" } else { "" }
    );
    for p in problems.iter().take(500) {
        let time = playback
            .and_then(|pb| pb.time_of_line(p.line))
            .map_or(String::new(), |t| format!("{t:.3}"));
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.4}</td><td>{}</td><td>{time}</td></tr>",
            p.line,
            kind_name(p.kind),
            p.value,
            p.layer.map_or(String::new(), |l| l.to_string())
        );
    }
    let _ = writeln!(h, "</table>");
}

/// The pictures: the overview, then the first lines of each problem kind
/// with the time at which program.glb shows them.
fn pictures_section(h: &mut String, pictures: &Pictures) {
    let _ = writeln!(h, "<h2>The program, seen</h2>");
    if let Some(why) = &pictures.missing {
        let _ = writeln!(h, "<p id=\"no-pictures\">No pictures: {}.</p>", esc(why));
        return;
    }
    let _ = writeln!(
        h,
        "<p>program.glb plays the program in its own time (open it in any glTF viewer: Blender, a three.js viewer); each picture gives the time of its line. Colours: printing blue, travel grey, collision red, tip deviation orange, tip speed yellow, swing purple, blob brown, long travel turn teal; in the pictures the part's triangles within the margin of the head are magenta, the head's cyan. Rendered on {}.</p>",
        esc(&pictures.adapter)
    );
    if let Some(png) = &pictures.overview {
        let _ = writeln!(
            h,
            "<figure id=\"overview\"><figcaption>The toolpath, coloured by what each line does</figcaption>{}</figure>",
            img(png, "the whole toolpath")
        );
    }
    for p in &pictures.problems {
        let _ = writeln!(
            h,
            "<figure class=\"problem\" id=\"{}-{}\" data-line=\"{}\" data-time=\"{:.3}\"><figcaption>{} at line {} (value {:.4}): {:.3} s into program.glb{}</figcaption>{}</figure>",
            kind_name(p.kind).replace(' ', "-"),
            p.line,
            p.line,
            p.time_s,
            kind_name(p.kind),
            p.line,
            p.value,
            p.time_s,
            if p.kind == ProblemKind::Collision {
                format!("; {} part triangles within the margin", p.highlighted)
            } else {
                String::new()
            },
            img(&p.png, &format!("the machine at line {}", p.line))
        );
    }
}

/// A PNG inline.
fn img(png: &[u8], alt: &str) -> String {
    use base64::Engine;
    format!(
        "<img alt=\"{}\" src=\"data:image/png;base64,{}\">",
        esc(alt),
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

/// The page up to its heading and the part model:
/// `<title>maamplan {kind} — source</title>`, `<h1>{heading}: source</h1>`.
fn page_start(kind: &str, heading: &str, ctx: &ReportContext) -> String {
    let mut h = String::new();
    let source = esc(ctx.source);
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>maamplan {kind} — {source}</title>\n<style>{STYLE}</style></head><body>\n",
    );
    let _ = writeln!(h, "<h1>{heading}: {source}</h1>");
    let _ = writeln!(
        h,
        "<p id=\"part\">Part model: {}.</p>",
        esc(ctx.part.name())
    );
    h
}

/// The run's warnings, the first 200 of them (report.json has all).
fn warnings_section(h: &mut String, warnings: &[String]) {
    if warnings.is_empty() {
        return;
    }
    let _ = writeln!(h, "<h2>Warnings</h2><ul id=\"warnings\">");
    for w in warnings.iter().take(200) {
        let _ = writeln!(h, "<li>{}</li>", esc(w));
    }
    if warnings.len() > 200 {
        let _ = writeln!(h, "<li>… {} more in report.json</li>", warnings.len() - 200);
    }
    let _ = writeln!(h, "</ul>");
}

/// The machine and the command, and the page's end.
fn page_end(mut h: String, m: &Machine, command: &str) -> String {
    let _ = writeln!(h, "<h2>Machine</h2><pre>{}</pre>", esc(&m.to_toml()));
    let _ = writeln!(
        h,
        "<h2>Command</h2><pre>{}</pre>\n</body></html>",
        esc(command)
    );
    h
}

/// The plots: at most [`REPORT_LAYER_FIGURES`] of the per-layer B/C
/// figures (with a note saying where the rest are, `elsewhere`), then the
/// others.
fn plots_section(h: &mut String, figures: &[Figure], elsewhere: &str) {
    let _ = writeln!(h, "<h2>Plots</h2>");
    let layers = figures
        .iter()
        .filter(|f| f.name.starts_with("bc_layer_"))
        .count();
    let shown = shown_layers(layers, REPORT_LAYER_FIGURES);
    if shown.len() < layers {
        let _ = writeln!(
            h,
            "<p id=\"sampled\">B and C of {} of the {layers} layers, evenly spaced; {elsewhere}.</p>",
            shown.len()
        );
    }
    embed_figures(h, figures, |f| match f.name.strip_prefix("bc_layer_") {
        Some(k) => k.parse().is_ok_and(|k: usize| shown.contains(&k)),
        None => true,
    });
}

/// Each figure of `figures` that `show` keeps, inline.
fn embed_figures(h: &mut String, figures: &[Figure], show: impl Fn(&Figure) -> bool) {
    for f in figures.iter().filter(|f| show(f)) {
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
}

#[cfg(test)]
mod tests {
    use super::shown_layers;

    #[test]
    fn shown_layers_are_evenly_spaced_with_both_ends() {
        assert_eq!(shown_layers(5, 24), vec![0, 1, 2, 3, 4]);
        let s = shown_layers(169, 24);
        assert_eq!(s.len(), 24);
        assert_eq!((s[0], s[23]), (0, 168));
        let gaps: Vec<usize> = s.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().all(|&g| (7..=8).contains(&g)), "{gaps:?}");
    }
}
