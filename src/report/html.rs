//! `report.html`: one self-contained page (plots inline as SVG, no
//! network): the input-vs-plan summary, the per-layer table, the plots, the
//! machine and the command that produced it.

use super::layer_table;
use super::plots::Figure;
use crate::kinematics::Machine;
use crate::plan::metrics::Metrics;
use crate::plan::Plan;
use std::fmt::Write;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn rows(i: &Metrics, p: &Metrics) -> Vec<(&'static str, String, String)> {
    vec![
        (
            "waypoints",
            i.waypoints.to_string(),
            p.waypoints.to_string(),
        ),
        (
            "residual collisions",
            i.residual_collisions.to_string(),
            p.residual_collisions.to_string(),
        ),
        (
            "colliding edges",
            i.colliding_edges.to_string(),
            p.colliding_edges.to_string(),
        ),
        (
            "tip-speed violations",
            format!("{:.2} %", i.speed_violation_pct),
            format!("{:.2} %", p.speed_violation_pct),
        ),
        (
            "J = Σ |ΔB| + |ΔC|",
            format!("{:.0}°", i.j_deg),
            format!("{:.0}°", p.j_deg),
        ),
        (
            "largest step",
            format!("{:.1}°", i.max_step_deg),
            format!("{:.1}°", p.max_step_deg),
        ),
        (
            "singular waypoints",
            i.singular_waypoints.to_string(),
            p.singular_waypoints.to_string(),
        ),
        ("breaks", i.breaks.to_string(), p.breaks.to_string()),
        (
            "axis-limit violations",
            i.axis_limit_violations.to_string(),
            p.axis_limit_violations.to_string(),
        ),
        (
            "orientation change (mean / max)",
            "—".into(),
            format!("{:.1}° / {:.1}°", p.mean_deviation_deg, p.max_deviation_deg),
        ),
    ]
}

/// The page.
pub fn report_html(
    source: &str,
    command: &str,
    m: &Machine,
    plan: &Plan,
    figures: &[Figure],
    seconds: f64,
) -> String {
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
    let _ = writeln!(
        h,
        "<h2>Summary</h2><table id=\"summary\"><tr><th></th><th>input</th><th>plan</th></tr>"
    );
    for (k, a, b) in rows(&plan.input, &plan.plan) {
        let _ = writeln!(h, "<tr><td>{k}</td><td>{a}</td><td>{b}</td></tr>");
    }
    let _ = writeln!(h, "</table>");
    let _ = writeln!(h, "<h2>Per layer</h2><table id=\"layers\"><tr><th>layer</th><th>waypoints</th><th>colliding (input)</th><th>residual (plan)</th></tr>");
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
