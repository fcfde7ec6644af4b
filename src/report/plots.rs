//! Plots with `plotters`, each as SVG (for the HTML report) and PNG:
//! B and C per waypoint of each layer, input vs plan, with the singular
//! band shaded (paper 000, Fig. 8); the tip-speed histogram, input vs plan,
//! with [v_min, v_max] marked (Fig. 10); colliding waypoints per layer.
//! The text uses the embedded DejaVu Sans (datasets/fonts), so plots look
//! the same on every machine.

use super::{layer_table, tip_speeds};
use crate::io::output::FolderFile;
use crate::kinematics::Machine;
use crate::plan::Plan;
use crate::simulate::{MoveReport, Simulation};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Once;

const FONT: &[u8] = include_bytes!("../../datasets/fonts/DejaVuSans.ttf");
const INPUT: RGBColor = RGBColor(150, 150, 150);
const PLAN: RGBColor = RGBColor(31, 119, 180);
const BAND: RGBColor = RGBColor(255, 200, 120);
const SIZE: (u32, u32) = (900, 520);

/// A plot: its file stem, title and SVG text.
pub struct Figure {
    /// File stem under `plots/`.
    pub name: String,
    /// Caption.
    pub title: String,
    /// The SVG document.
    pub svg: String,
}

fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // A failure leaves plotters without text, never without plots.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

type DrawResult = Result<(), String>;

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// The series' legend, boxed, at `position` (plotters puts it at the
/// middle of the right edge unless told otherwise).
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    c: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> DrawResult {
    c.configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

/// One figure drawn into an SVG string of the report's size.
fn svg_figure(
    name: String,
    title: String,
    draw: &dyn Fn(DrawingArea<SVGBackend, Shift>) -> DrawResult,
) -> Result<Figure, String> {
    let mut svg = String::new();
    draw(SVGBackend::with_string(&mut svg, SIZE).into_drawing_area())?;
    Ok(Figure { name, title, svg })
}

/// One of the plan's charts.
#[derive(Clone, Copy)]
enum PlanChart {
    /// B and C per waypoint of a layer.
    Layer(usize),
    /// The tip-speed histogram.
    TipSpeed,
    /// Colliding waypoints per layer.
    Collisions,
}

impl PlanChart {
    /// Every chart of `plan`, in the report's order.
    fn all(plan: &Plan) -> Vec<PlanChart> {
        let layers = layer_table(plan).len();
        (0..layers)
            .map(PlanChart::Layer)
            .chain([PlanChart::TipSpeed, PlanChart::Collisions])
            .collect()
    }

    fn name(self) -> String {
        match self {
            PlanChart::Layer(k) => format!("bc_layer_{k}"),
            PlanChart::TipSpeed => "tip_speed".into(),
            PlanChart::Collisions => "collisions".into(),
        }
    }

    fn title(self) -> String {
        match self {
            PlanChart::Layer(k) => format!("Layer {k}: B and C per waypoint"),
            PlanChart::TipSpeed => "Tip speed per segment".into(),
            PlanChart::Collisions => "Colliding waypoints per layer".into(),
        }
    }

    fn draw<DB: DrawingBackend>(
        self,
        root: DrawingArea<DB, Shift>,
        m: &Machine,
        plan: &Plan,
    ) -> DrawResult {
        match self {
            PlanChart::Layer(k) => bc_chart(root, plan, k),
            PlanChart::TipSpeed => speed_chart(root, m, plan),
            PlanChart::Collisions => collision_chart(root, plan),
        }
    }

    fn svg(self, m: &Machine, plan: &Plan) -> Result<Figure, String> {
        svg_figure(self.name(), self.title(), &|root| self.draw(root, m, plan))
    }
}

/// Every figure of `plan` (drawn in parallel, returned in order).
pub fn figures(m: &Machine, plan: &Plan) -> Result<Vec<Figure>, String> {
    fonts();
    PlanChart::all(plan)
        .par_iter()
        .map(|c| c.svg(m, plan))
        .collect()
}

/// Every figure of `plan`, and the files of its plots folder:
/// `plots/<name>.svg` and `plots/<name>.png` per figure. Figures are drawn
/// in parallel and returned in order.
pub fn figure_files(m: &Machine, plan: &Plan) -> Result<(Vec<Figure>, Vec<FolderFile>), String> {
    fonts();
    let drawn: Vec<(Figure, Vec<u8>)> = PlanChart::all(plan)
        .par_iter()
        .map(|c| {
            let f = c.svg(m, plan)?;
            let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            c.draw(
                BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area(),
                m,
                plan,
            )?;
            Ok((f, encode_png(&rgb)?))
        })
        .collect::<Result<_, String>>()?;
    let mut files = Vec::with_capacity(2 * drawn.len());
    let mut figures = Vec::with_capacity(drawn.len());
    for (f, png) in drawn {
        let dir = Path::new("plots");
        files.push((
            dir.join(format!("{}.svg", f.name)),
            f.svg.clone().into_bytes(),
        ));
        files.push((dir.join(format!("{}.png", f.name)), png));
        figures.push(f);
    }
    Ok((figures, files))
}

/// An RGB image of [`SIZE`] as PNG: fdeflate's fast mode and the Paeth
/// filter on every row, which makes files of about the size trying every
/// filter on every row makes, in a fraction of the time.
fn encode_png(rgb: &[u8]) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    let mut png = png::Encoder::new(&mut bytes, SIZE.0, SIZE.1);
    png.set_color(png::ColorType::Rgb);
    png.set_depth(png::BitDepth::Eight);
    png.set_compression(png::Compression::Fast);
    png.set_filter(png::Filter::Paeth);
    let mut writer = png.write_header().map_err(err)?;
    writer.write_image_data(rgb).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(bytes)
}

/// Buckets along x a per-waypoint line is drawn with (a few per pixel
/// column of the chart).
const LINE_BUCKETS: usize = 400;

/// A line of many points drawn as it looks: per bucket of consecutive
/// points, the lowest and the highest, in order, so spikes survive and
/// the figure's size stays bounded (the full data is in plan.csv).
pub fn envelope(points: &[(f64, f64)], buckets: usize) -> Vec<(f64, f64)> {
    if points.len() <= 2 * buckets {
        return points.to_vec();
    }
    let per = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 1);
    for chunk in points.chunks(per) {
        let lo = chunk
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("chunk");
        let hi = chunk
            .iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("chunk");
        let (a, b) = if lo.0 <= hi.0 { (lo, hi) } else { (hi, lo) };
        out.push(*a);
        if b != a {
            out.push(*b);
        }
    }
    out
}

fn bc_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    plan: &Plan,
    layer: usize,
) -> DrawResult {
    // The layer's waypoints are one run of the plan, found by bisection,
    // not a pass over every waypoint per chart: a part of hundreds of
    // layers draws hundreds of charts, each twice (SVG and PNG).
    let (w, idx) = (&plan.waypoints, plan.layer_waypoints(layer));
    let bc = |a: &crate::kinematics::Axes| [a.tilt.to_degrees(), a.c.to_degrees()];
    let inp: Vec<[f64; 2]> = plan.input_axes[idx.clone()].iter().map(bc).collect();
    let pl: Vec<[f64; 2]> = w[idx].iter().map(|p| bc(&p.axes)).collect();
    bc_lines(
        root,
        layer,
        plan.alpha.to_degrees(),
        "waypoint",
        &[("input", INPUT, 1, &inp), ("plan", PLAN, 2, &pl)],
    )
}

/// A line of B/C values: label, colour, stroke width, `[B°, C°]` per point.
type BcLine<'a> = (&'a str, RGBColor, u32, &'a [[f64; 2]]);

/// B (top, with the singular band |B| ≤ `alpha` shaded) and C (bottom) of
/// one layer, one line per entry of `lines`, against the point's index.
fn bc_lines<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    layer: usize,
    alpha: f64,
    x_desc: &str,
    lines: &[BcLine],
) -> DrawResult {
    root.fill(&WHITE).map_err(err)?;
    let (top, bottom) = root.split_vertically(SIZE.1 / 2);
    for (area, k) in [(top, 0usize), (bottom, 1)] {
        let pts: Vec<Vec<(f64, f64)>> = lines
            .iter()
            .map(|l| {
                l.3.iter()
                    .enumerate()
                    .map(|(i, v)| (i as f64, v[k]))
                    .collect()
            })
            .collect();
        let (lo, hi) = pts
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                (l.min(p.1), h.max(p.1))
            });
        let (lo, hi) = if lo.is_finite() {
            (lo - 1.0, hi + 1.0)
        } else {
            (-1.0, 1.0)
        };
        let n = lines.iter().map(|l| l.3.len()).max().unwrap_or(0).max(2) as f64;
        let mut c = ChartBuilder::on(&area)
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(56)
            .caption(
                if k == 0 {
                    format!("layer {layer}: B (°)")
                } else {
                    format!("layer {layer}: C (°, unwound)")
                },
                ("sans-serif", 16),
            )
            .build_cartesian_2d(0.0..n, lo..hi)
            .map_err(err)?;
        c.configure_mesh()
            .x_desc(x_desc)
            .light_line_style(WHITE)
            .draw()
            .map_err(err)?;
        if k == 0 {
            // The singular region: |B| ≤ α.
            c.draw_series(std::iter::once(Rectangle::new(
                [(0.0, -alpha), (n, alpha)],
                BAND.mix(0.5).filled(),
            )))
            .map_err(err)?
            .label(format!("singular |B| ≤ {alpha:.1}°"))
            .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], BAND.filled()));
        }
        for (l, p) in lines.iter().zip(pts) {
            let color = l.1;
            c.draw_series(LineSeries::new(
                envelope(&p, LINE_BUCKETS),
                color.stroke_width(l.2),
            ))
            .map_err(err)?
            .label(l.0)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 12, y)], color));
        }
        legend(&mut c, SeriesLabelPosition::MiddleRight)?;
    }
    root.present().map_err(err)
}

fn speed_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    m: &Machine,
    plan: &Plan,
) -> DrawResult {
    let (inp, pl) = tip_speeds(m, plan);
    histogram(
        root,
        "tip speed over the part (mm/s), input vs plan",
        "segments",
        m.tip_speed[1] * 1.2,
        m.tip_speed,
        &[("input", INPUT, &inp), ("plan", PLAN, &pl)],
    )
}

fn collision_chart<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, plan: &Plan) -> DrawResult {
    let t = layer_table(plan);
    let inp: Vec<usize> = t.iter().map(|r| r.1).collect();
    let pl: Vec<usize> = t.iter().map(|r| r.2).collect();
    bars(
        root,
        "colliding waypoints per layer, input vs plan",
        "waypoints",
        &[("input", INPUT, &inp), ("plan", PLAN, &pl)],
    )
}

/// A series of a histogram or bar chart: label, colour, values.
type Series<'a, T> = (&'a str, RGBColor, &'a [T]);

/// Values in 60 bins over `[0, top)` (larger ones in the last), side by
/// side per series on a log scale, with `[v_min, v_max]` marked.
fn histogram<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    caption: &str,
    y_desc: &str,
    top: f64,
    [vmin, vmax]: [f64; 2],
    series: &[Series<f64>],
) -> DrawResult {
    root.fill(&WHITE).map_err(err)?;
    let bins = 60usize;
    let w = top / bins as f64;
    let hist = |v: &[f64]| {
        let mut h = vec![0usize; bins];
        for &x in v {
            h[((x / w) as usize).min(bins - 1)] += 1;
        }
        h
    };
    let hs: Vec<Vec<usize>> = series.iter().map(|s| hist(s.2)).collect();
    let ymax = hs.iter().flatten().copied().max().unwrap_or(1).max(1) as f64;
    let mut c = ChartBuilder::on(&root)
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .caption(caption, ("sans-serif", 18))
        .build_cartesian_2d(0.0..top, (0.5..ymax * 2.0).log_scale())
        .map_err(err)?;
    c.configure_mesh()
        .x_desc("mm/s")
        .y_desc(y_desc)
        .light_line_style(WHITE)
        .draw()
        .map_err(err)?;
    c.draw_series(
        [vmin, vmax].map(|v| PathElement::new([(v, 0.5), (v, ymax * 2.0)], RED.stroke_width(2))),
    )
    .map_err(err)?
    .label(format!("[v_min, v_max] = [{vmin}, {vmax}]"))
    .legend(|(x, y)| PathElement::new([(x, y), (x + 12, y)], RED));
    let share = 1.0 / series.len().max(1) as f64;
    for (k, (&(label, color, _), h)) in series.iter().zip(&hs).enumerate() {
        let off = k as f64 * share;
        c.draw_series(h.iter().enumerate().filter(|(_, &n)| n > 0).map(|(b, &n)| {
            let x0 = b as f64 * w + off * w;
            Rectangle::new([(x0, 0.5), (x0 + share * w, n as f64)], color.filled())
        }))
        .map_err(err)?
        .label(label)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    legend(&mut c, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(err)
}

/// Linear axes on a whole page: the report's margins, a caption, `y_label`
/// pixels for the y labels and a light grid.
fn linear_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    caption: &str,
    y_label: u32,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    x_desc: &str,
    y_desc: Option<&str>,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, String> {
    let mut c = ChartBuilder::on(root)
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(y_label)
        .caption(caption, ("sans-serif", 18))
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    let mut mesh = c.configure_mesh();
    mesh.x_desc(x_desc);
    if let Some(d) = y_desc {
        mesh.y_desc(d);
    }
    mesh.light_line_style(WHITE).draw().map_err(err)?;
    Ok(c)
}

/// Per layer, one bar per series side by side.
fn bars<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    caption: &str,
    y_desc: &str,
    series: &[Series<usize>],
) -> DrawResult {
    root.fill(&WHITE).map_err(err)?;
    let ymax = series
        .iter()
        .flat_map(|s| s.2.iter().copied())
        .max()
        .unwrap_or(0)
        .max(1) as f64
        * 1.15;
    let n = series.iter().map(|s| s.2.len()).max().unwrap_or(0).max(1) as f64;
    let mut c = linear_chart(&root, caption, 60, 0.0..n, 0.0..ymax, "layer", Some(y_desc))?;
    let width = 0.8 / series.len().max(1) as f64;
    for (k, &(label, color, v)) in series.iter().enumerate() {
        let off = 0.1 + k as f64 * width;
        c.draw_series(v.iter().enumerate().map(|(l, &y)| {
            Rectangle::new(
                [(l as f64 + off, 0.0), (l as f64 + off + width, y as f64)],
                color.filled(),
            )
        }))
        .map_err(err)?
        .label(label)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    legend(&mut c, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(err)
}

/// The figures of a simulation ([`crate::simulate`]): tip speed of the
/// extruding lines against the extruder's range, tip deviation and rotary
/// step along the program, colliding lines per layer.
pub fn simulation_figures(m: &Machine, sim: &Simulation) -> Result<Vec<Figure>, String> {
    fonts();
    let ext: Vec<&MoveReport> = sim.moves.iter().filter(|r| r.extrudes).collect();
    let along = |f: &dyn Fn(&MoveReport) -> f64| -> Vec<(f64, f64)> {
        ext.iter()
            .enumerate()
            .map(|(k, r)| (k as f64, f(r)))
            .collect()
    };
    let speeds: Vec<f64> = ext.iter().map(|r| r.tip_speed).collect();
    let dev = along(&|r| r.deviation_mm);
    let step = along(&|r| r.rotary_step_deg);
    let layers = sim
        .moves
        .iter()
        .filter_map(|r| r.layer)
        .max()
        .map_or(0, |l| l + 1);
    let mut per_layer = vec![0usize; layers.max(1)];
    for r in sim.moves.iter().filter(|r| r.collides) {
        per_layer[r.layer.unwrap_or(0)] += 1;
    }
    let mut out = Vec::new();
    let mut svg = |name: &str,
                   title: &str,
                   draw: &dyn Fn(DrawingArea<SVGBackend, Shift>) -> DrawResult|
     -> DrawResult {
        out.push(svg_figure(name.into(), title.into(), draw)?);
        Ok(())
    };
    let alpha = crate::plan::PlanOptions::default().alpha.to_degrees();
    // Each layer's extruding lines in program order, gathered in one pass.
    let mut bc_of = vec![Vec::new(); layers];
    for r in &ext {
        if let Some(k) = r.layer {
            bc_of[k].push([r.tilt_deg, r.c_deg]);
        }
    }
    for (k, bc) in bc_of.iter().enumerate() {
        svg(
            &format!("bc_layer_{k}"),
            &format!("Layer {k}: B and C per extruding line"),
            &|root| {
                bc_lines(
                    root,
                    k,
                    alpha,
                    "extruding line",
                    &[("program", PLAN, 2, bc)],
                )
            },
        )?;
    }
    svg("tip_speed", "Tip speed per extruding line", &|root| {
        let top = speeds.iter().copied().fold(m.tip_speed[1] * 1.2, f64::max);
        histogram(
            root,
            "tip speed over the part (mm/s)",
            "lines",
            top,
            m.tip_speed,
            &[("program", PLAN, &speeds)],
        )
    })?;
    svg(
        "tip_deviation",
        "Tip deviation from the bead per extruding line",
        &|root| line_chart(root, "tip deviation (mm)", &dev, Some(m.tip_tolerance)),
    )?;
    svg("rotary_step", "Rotary step per extruding line", &|root| {
        line_chart(
            root,
            "|Δtilt| + |ΔC| (°)",
            &step,
            Some(crate::simulate::measure::SWING_DEG),
        )
    })?;
    svg("collisions", "Colliding lines per layer", &|root| {
        bars(
            root,
            "colliding lines per layer",
            "lines",
            &[("program", PLAN, &per_layer)],
        )
    })?;
    Ok(out)
}

fn line_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    caption: &str,
    pts: &[(f64, f64)],
    limit: Option<f64>,
) -> DrawResult {
    root.fill(&WHITE).map_err(err)?;
    let n = pts.len().max(2) as f64;
    let hi = pts
        .iter()
        .map(|p| p.1)
        .chain(limit)
        .fold(0.0, f64::max)
        .max(1e-3)
        * 1.1;
    let mut c = linear_chart(&root, caption, 70, 0.0..n, 0.0..hi, "extruding line", None)?;
    if let Some(l) = limit {
        c.draw_series(std::iter::once(PathElement::new(
            [(0.0, l), (n, l)],
            RED.stroke_width(2),
        )))
        .map_err(err)?
        .label(format!("limit {l}"))
        .legend(|(x, y)| PathElement::new([(x, y), (x + 12, y)], RED));
    }
    c.draw_series(LineSeries::new(
        envelope(pts, LINE_BUCKETS),
        PLAN.stroke_width(1),
    ))
    .map_err(err)?
    .label("program")
    .legend(|(x, y)| PathElement::new([(x, y), (x + 12, y)], PLAN));
    legend(&mut c, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(err)
}

#[cfg(test)]
mod tests {
    use super::envelope;

    #[test]
    fn envelope_keeps_every_buckets_extremes_and_bounds_the_size() {
        let pts: Vec<(f64, f64)> = (0..10_000)
            .map(|i| {
                (
                    i as f64,
                    ((i * 7919) % 1000) as f64 + if i == 4321 { 1e4 } else { 0.0 },
                )
            })
            .collect();
        let e = envelope(&pts, 100);
        assert!(e.len() <= 200, "{}", e.len());
        assert!(e.windows(2).all(|w| w[0].0 < w[1].0), "x order kept");
        // The plain loop: each bucket's lowest and highest values survive.
        for chunk in pts.chunks(100) {
            let lo = chunk.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            let hi = chunk.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
            let kept: Vec<f64> = e
                .iter()
                .filter(|p| p.0 >= chunk[0].0 && p.0 <= chunk[chunk.len() - 1].0)
                .map(|p| p.1)
                .collect();
            assert!(kept.contains(&lo) && kept.contains(&hi));
        }
        assert!(e.iter().any(|p| p.1 >= 1e4), "the spike is drawn");
        // Short lines are drawn as they are.
        assert_eq!(envelope(&pts[..150], 100), pts[..150].to_vec());
    }
}
