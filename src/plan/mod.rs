//! The planner (paper 000, Algorithm 1): from waypoints to machine axes.
//!
//! Per continuous section of a layer (a layer splits where consecutive
//! waypoints are more than `jump` mm apart):
//! 1. smooth the orientations ([`smooth`]);
//! 2. give singular runs their rotary angles ([`singular`]);
//! 3. check every waypoint's pose, both IK solutions, in one batch;
//! 4. sample collision-free variants for the colliding ones, in batches
//!    ([`candidates`]);
//! 5. find the shortest path through the layered graph of configurations
//!    ([`graph`]), checking the motion along the chosen path's edges in
//!    batches and re-solving without the colliding ones;
//! 6. unwind C, compute X, Y, Z (Table I) and the extrusion (Eq. 1).
//!
//! The input is measured the same way (direct IK, C unwound, orientations
//! unchanged) so the report compares like with like ([`metrics`]).

pub mod candidates;
pub mod graph;
pub mod metrics;
pub mod motion;
pub mod singular;
pub mod smooth;

use crate::collide::{Backend, CollideError};
use crate::kinematics::{head_pose, ik_angles, linear_axes, orientation, wrap, Axes, Machine};
use crate::scene::{Query, Scene};
use crate::toolpath::Toolpath;
use candidates::Sampling;
use metrics::{Metrics, SegmentStats};
use rayon::prelude::*;
use smooth::Smoothing;
use std::collections::HashSet;
use std::time::Instant;

/// What can go wrong planning.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A collision backend failed.
    #[error(transparent)]
    Collide(#[from] CollideError),
    /// The scene was built from another toolpath.
    #[error(
        "the scene has {0} waypoints but the toolpath {1}: build the scene from this toolpath"
    )]
    Mismatch(usize, usize),
}

/// Planner settings.
#[derive(Clone, Copy, Debug)]
pub struct PlanOptions {
    /// Orientation smoothing.
    pub smoothing: Smoothing,
    /// Singular region half-angle α (radians), Eq. 6.
    pub alpha: f64,
    /// Variant cone half-angle β (radians).
    pub beta: f64,
    /// Variant generation.
    pub sampling: Sampling,
    /// Largest movement of any head point between two motion checks (mm).
    pub edge_step: f64,
    /// Consecutive waypoints farther apart than this start a new section (mm).
    pub jump: f64,
    /// Paper 002's interval subsampling: solve every `subsample`-th column
    /// first, then the intervals (1 = exact, the default).
    pub subsample: usize,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            smoothing: Smoothing::Laplacian { passes: 8 },
            alpha: 4.5f64.to_radians(),
            beta: 45f64.to_radians(),
            sampling: Sampling::Random { k: 24 },
            edge_step: 0.5,
            jump: 5.0,
            subsample: 1,
        }
    }
}

/// One planned waypoint.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedWaypoint {
    /// Layer index.
    pub layer: usize,
    /// Tip position, part frame (mm).
    pub p: [f64; 3],
    /// Planned nozzle direction, part frame.
    pub n: [f64; 3],
    /// Machine axes (C unwound along the section).
    pub axes: Axes,
    /// Cumulative extrusion within the layer (mm of filament).
    pub e: f64,
    /// First waypoint of a section (travel before it).
    pub section_start: bool,
    /// Entered through a break (lift and travel) inside a section.
    pub break_before: bool,
    /// The input orientation collided.
    pub was_colliding: bool,
    /// The input orientation was in the singular region.
    pub singular: bool,
    /// No collision-free configuration was found.
    pub residual: bool,
}

/// A plan and its report.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Waypoints in print order.
    pub waypoints: Vec<PlannedWaypoint>,
    /// Metrics of the input (direct IK).
    pub input: Metrics,
    /// Metrics of the plan.
    pub plan: Metrics,
    /// Seconds per stage, in order.
    pub stages: Vec<(String, f64)>,
    /// The input's machine axes (direct IK, C unwound), per waypoint.
    pub input_axes: Vec<Axes>,
    /// The singular region's half-angle used (radians).
    pub alpha: f64,
}

/// Does a half-turn about the head axis map the head onto itself? Then the
/// two IK solutions are the same collision query.
pub fn half_turn_symmetric(scene: &Scene) -> bool {
    let v = &scene.head.mesh.vertices;
    let key = |p: [f32; 3]| {
        [
            (p[0] * 1e4).round() as i64,
            (p[1] * 1e4).round() as i64,
            (p[2] * 1e4).round() as i64,
        ]
    };
    let set: HashSet<[i64; 3]> = v.iter().map(|p| key(*p)).collect();
    v.iter().all(|p| set.contains(&key([-p[0], -p[1], p[2]])))
}

struct Ctx<'a> {
    scene: &'a Scene,
    machine: &'a Machine,
    backend: &'a dyn Backend,
    symmetric: bool,
    reach: f64,
    edge_step: f64,
}

impl Ctx<'_> {
    fn axes(&self, p: [f64; 3], (t, c): (f64, f64)) -> Axes {
        let m = self.machine;
        Axes {
            xyz: linear_axes(m.configuration, m.rotary, m.offsets(), p, t, c),
            tilt: t,
            c,
        }
    }

    /// Verdicts for configurations `(waypoint, (tilt, c))`.
    fn check_configs(
        &self,
        items: &[(usize, (f64, f64))],
        pos: &[[f64; 3]],
    ) -> Result<Vec<bool>, PlanError> {
        let rot = self.machine.rotary;
        let queries: Vec<Query> = items
            .par_iter()
            .map(|&(i, (t, c))| Query {
                pose: head_pose(rot, pos[i], t, c),
                cutoff: self.scene.waypoint_queries[i].cutoff,
                margin: 0.0,
            })
            .collect();
        Ok(self.backend.evaluate(&queries)?)
    }

    /// Do the moves `(waypoint i, a) → (waypoint i + 1, b)` collide? Checks
    /// are `step` mm of head motion apart.
    fn check_moves(
        &self,
        moves: &[(usize, Axes, Axes)],
        step: f64,
        max_samples: usize,
    ) -> Result<Vec<bool>, PlanError> {
        let per: Vec<Vec<Query>> = moves
            .par_iter()
            .map(|(i, a, b)| {
                let mut q = Vec::new();
                let cutoff = self.scene.waypoint_queries[*i].cutoff;
                motion::between(
                    self.machine,
                    a,
                    b,
                    cutoff,
                    self.reach,
                    step,
                    max_samples,
                    &mut q,
                );
                q
            })
            .collect();
        let flat: Vec<Query> = per.iter().flatten().copied().collect();
        let verdicts = self.backend.evaluate(&flat)?;
        let mut out = Vec::with_capacity(moves.len());
        let mut k = 0;
        for q in &per {
            out.push(verdicts[k..k + q.len()].iter().any(|&v| v));
            k += q.len();
        }
        Ok(out)
    }
}

/// Plan `toolpath` (whose scene is `scene`) for `machine`, answering every
/// collision question with `backend`. `progress` hears each stage's name.
pub fn plan(
    scene: &Scene,
    toolpath: &Toolpath,
    machine: &Machine,
    backend: &dyn Backend,
    opts: &PlanOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Plan, PlanError> {
    let n_wp = toolpath.waypoint_count();
    if scene.waypoint_queries.len() != n_wp {
        return Err(PlanError::Mismatch(scene.waypoint_queries.len(), n_wp));
    }
    let mut stages = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, stages: &mut Vec<(String, f64)>| {
        stages.push((name.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };
    let reach = scene
        .head
        .mesh
        .vertices
        .iter()
        .map(|v| (v[0] as f64).hypot(v[1] as f64).hypot(v[2] as f64))
        .fold(0.0, f64::max);
    let ctx = Ctx {
        scene,
        machine,
        backend,
        symmetric: half_turn_symmetric(scene),
        reach,
        edge_step: opts.edge_step.max(1e-3),
    };
    let rot = machine.rotary;

    // Flatten the toolpath and split it into sections.
    let mut pos = Vec::with_capacity(n_wp);
    let mut n0 = Vec::with_capacity(n_wp);
    let mut layer_of = Vec::with_capacity(n_wp);
    let mut sections: Vec<std::ops::Range<usize>> = Vec::new();
    for (k, layer) in toolpath.layers.iter().enumerate() {
        // A section starts with each layer and after each jump.
        let mut start = pos.len();
        for w in &layer.waypoints {
            let p = w.pos.map(|x| x as f64);
            if pos.len() > start {
                let q: [f64; 3] = pos[pos.len() - 1];
                if (p[0] - q[0]).hypot(p[1] - q[1]).hypot(p[2] - q[2]) > opts.jump {
                    sections.push(start..pos.len());
                    start = pos.len();
                }
            }
            pos.push(p);
            let d = w.dir.map(|x| x as f64);
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            n0.push(d.map(|x| x / l));
            layer_of.push(k);
        }
        if start < pos.len() {
            sections.push(start..pos.len());
        }
    }

    // 1–2: smoothing and singular processing, section by section.
    progress("smoothing");
    let mut n1 = vec![[0.0; 3]; n_wp];
    for r in &sections {
        n1[r.clone()].copy_from_slice(&smooth::smooth(&n0[r.clone()], opts.smoothing));
    }
    lap("smooth", &mut stages);
    progress("singularities");
    let mut fixed = vec![None; n_wp];
    let mut singular = vec![false; n_wp];
    for r in &sections {
        let (f, s) = singular::process(rot, &n1[r.clone()], opts.alpha);
        fixed[r.clone()].clone_from_slice(&f);
        singular[r.clone()].copy_from_slice(&s);
    }
    // Each waypoint's base configurations: the singular angles and their
    // mirror, or both IK solutions of the smoothed orientation.
    let base: Vec<[(f64, f64); 2]> = (0..n_wp)
        .map(|i| match fixed[i] {
            Some((t, c)) => [(t, c), (-t, wrap(c + std::f64::consts::PI))],
            None => ik_angles(rot, n1[i]),
        })
        .collect();
    lap("singularities", &mut stages);

    // 3: every base configuration in one batch.
    progress("collisions");
    let items: Vec<(usize, (f64, f64))> = (0..n_wp)
        .flat_map(|i| {
            let k = if ctx.symmetric { 1 } else { 2 };
            base[i][..k]
                .iter()
                .map(move |&b| (i, b))
                .collect::<Vec<_>>()
        })
        .collect();
    let v = ctx.check_configs(&items, &pos)?;
    let mut cols: Vec<Vec<(f64, f64)>> = vec![Vec::new(); n_wp];
    for (k, &(i, b)) in items.iter().enumerate() {
        if !v[k] {
            cols[i].push(b);
            if ctx.symmetric {
                cols[i].push(base[i][1]);
            }
        }
    }
    lap("collisions", &mut stages);

    // 4: variants for waypoints with no free base configuration.
    progress("variants");
    let mut open: Vec<usize> = (0..n_wp).filter(|&i| cols[i].is_empty()).collect();
    let mut round = 0u32;
    while !open.is_empty() {
        let mut items = Vec::new();
        for &i in &open {
            let centre = fixed[i].map_or(n1[i], |(t, c)| orientation(rot, t, c));
            // The first round also offers the waypoint's own, unsmoothed
            // orientation: smoothing must not make a free waypoint collide.
            let own = (round == 0).then_some(n0[i]);
            // One sample pattern for every waypoint: neighbours get matching
            // candidates, so the graph can keep the motion smooth.
            let sampled = candidates::round(centre, 0, round, opts.sampling, opts.beta, opts.alpha);
            for d in own.into_iter().chain(sampled) {
                for (j, s) in ik_angles(rot, d).into_iter().enumerate() {
                    if j == 0 || !ctx.symmetric {
                        items.push((i, s));
                    }
                }
            }
        }
        if items.is_empty() {
            break; // Sampling exhausted: what is left stays colliding.
        }
        let v = ctx.check_configs(&items, &pos)?;
        for (k, &(i, s)) in items.iter().enumerate() {
            if !v[k] && cols[i].len() < 16 {
                cols[i].push(s);
                if ctx.symmetric {
                    cols[i].push((-s.0, wrap(s.1 + std::f64::consts::PI)));
                }
            }
        }
        open.retain(|&i| cols[i].is_empty());
        round += 1;
    }
    // Configurations the tilt axis cannot reach are dropped (kept only where
    // nothing else exists, and then reported).
    let (tmin, tmax) = (machine.tilt.min.to_radians(), machine.tilt.max.to_radians());
    for c in cols.iter_mut() {
        c.retain(|&(t, _)| t >= tmin - 1e-12 && t <= tmax + 1e-12);
    }
    let residual: Vec<bool> = (0..n_wp).map(|i| cols[i].is_empty()).collect();
    for i in 0..n_wp {
        if cols[i].is_empty() {
            cols[i] = base[i].to_vec();
        }
    }
    lap("variants", &mut stages);

    // 5: shortest paths with lazily checked motions.
    progress("graph");
    let mut chosen = vec![(0.0, 0.0); n_wp];
    let mut breaks = vec![false; n_wp];
    let mut colliding_edges = 0;
    let mut blocked: Vec<HashSet<(usize, usize, usize)>> = vec![HashSet::new(); sections.len()];
    let mut verified: Vec<HashSet<(usize, usize, usize)>> = vec![HashSet::new(); sections.len()];
    let mut paths: Vec<graph::Path> = sections
        .par_iter()
        .map(|r| graph::shortest_path_subsampled(&cols[r.clone()], &HashSet::new(), opts.subsample))
        .collect();
    for _ in 0..32 {
        let mut moves = Vec::new();
        let mut keys = Vec::new();
        for (s, r) in sections.iter().enumerate() {
            let p = &paths[s];
            for k in 1..r.len() {
                let key = (k, p.nodes[k - 1], p.nodes[k]);
                if p.breaks[k] || verified[s].contains(&key) {
                    continue;
                }
                let i = r.start + k - 1;
                let a = ctx.axes(pos[i], cols[i][key.1]);
                let mut bb = cols[i + 1][key.2];
                bb.1 = a.c + wrap(bb.1 - a.c);
                moves.push((i, a, ctx.axes(pos[i + 1], bb)));
                keys.push((s, key));
            }
        }
        if moves.is_empty() {
            break;
        }
        let v = ctx.check_moves(&moves, ctx.edge_step, usize::MAX)?;
        let mut dirty = HashSet::new();
        for (k, &(s, key)) in keys.iter().enumerate() {
            verified[s].insert(key);
            if v[k] {
                blocked[s].insert(key);
                dirty.insert(s);
            }
        }
        if dirty.is_empty() {
            break;
        }
        for s in dirty {
            paths[s] = graph::shortest_path_subsampled(
                &cols[sections[s].clone()],
                &blocked[s],
                opts.subsample,
            );
        }
    }
    for (s, r) in sections.iter().enumerate() {
        let p = &paths[s];
        for k in 0..r.len() {
            chosen[r.start + k] = cols[r.start + k][p.nodes[k]];
            breaks[r.start + k] = p.breaks[k];
            if k > 0 && !p.breaks[k] && blocked[s].contains(&(k, p.nodes[k - 1], p.nodes[k])) {
                colliding_edges += 1;
            }
        }
    }
    lap("graph", &mut stages);

    // 6: axes with C unwound, extrusion.
    progress("output");
    let heights = extrusion_heights(&pos, &layer_of, machine.extrusion.default_height);
    let mut out = Vec::with_capacity(n_wp);
    let mut section_start = vec![false; n_wp];
    for r in &sections {
        section_start[r.start] = true;
    }
    let mut e = 0.0;
    for i in 0..n_wp {
        let (t, mut c) = chosen[i];
        if i > 0 && !section_start[i] {
            let prev: &PlannedWaypoint = &out[i - 1];
            c = prev.axes.c + wrap(c - prev.axes.c);
        }
        if i == 0 || layer_of[i] != layer_of[i - 1] {
            e = 0.0;
        } else if !section_start[i] && !breaks[i] {
            let q = pos[i - 1];
            let len = (pos[i][0] - q[0])
                .hypot(pos[i][1] - q[1])
                .hypot(pos[i][2] - q[2]);
            let ex = &machine.extrusion;
            e += ex.k * 0.5 * (heights[i - 1] + heights[i]) * ex.width * len;
        }
        out.push(PlannedWaypoint {
            layer: layer_of[i],
            p: pos[i],
            n: orientation(rot, t, c),
            axes: ctx.axes(pos[i], (t, c)),
            e,
            section_start: section_start[i],
            break_before: breaks[i],
            was_colliding: false,
            singular: singular[i],
            residual: residual[i],
        });
    }
    lap("output", &mut stages);

    // Metrics: the plan, then the input measured the same way.
    progress("metrics");
    let mut plan_m = Metrics {
        waypoints: n_wp,
        residual_collisions: residual.iter().filter(|&&r| r).count(),
        colliding_edges,
        singular_waypoints: out
            .iter()
            .filter(|w| singular::is_singular(w.n, opts.alpha * (1.0 - 1e-9)))
            .count(),
        breaks: breaks.iter().filter(|&&b| b).count(),
        ..Metrics::default()
    };
    segment_stats(machine, &out, &sections).finish(&mut plan_m);
    let dev: Vec<f64> = out
        .iter()
        .zip(&n0)
        .map(|(w, n)| {
            (w.n[0] * n[0] + w.n[1] * n[1] + w.n[2] * n[2])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .collect();
    plan_m.max_deviation_deg = dev.iter().copied().fold(0.0, f64::max);
    plan_m.axis_limit_violations = out
        .iter()
        .filter(|w| metrics::outside_limits(machine, &w.axes))
        .count();
    plan_m.mean_deviation_deg = dev.iter().sum::<f64>() / dev.len().max(1) as f64;

    let input_axes = direct_ik(&ctx, &pos, &n0, &sections);
    let items: Vec<(usize, (f64, f64))> = (0..n_wp)
        .map(|i| (i, (input_axes[i].tilt, input_axes[i].c)))
        .collect();
    let hit = ctx.check_configs(&items, &pos)?;
    let mut moves = Vec::new();
    for r in &sections {
        for i in r.start..r.end.saturating_sub(1) {
            moves.push((i, input_axes[i], input_axes[i + 1]));
        }
    }
    // The input's moves only feed its report; its wild C swings (hundreds of
    // degrees between neighbours) would take millions of checks at the
    // plan's spacing, so they are checked 4× coarser and at most 16 times
    // each: its colliding-edge count is a lower bound.
    let edge_hits = ctx.check_moves(&moves, 4.0 * ctx.edge_step, 16)?;
    let input_wp: Vec<PlannedWaypoint> = (0..n_wp)
        .map(|i| PlannedWaypoint {
            axes: input_axes[i],
            n: n0[i],
            p: pos[i],
            break_before: false,
            ..out[i].clone()
        })
        .collect();
    let mut input_m = Metrics {
        waypoints: n_wp,
        residual_collisions: hit.iter().filter(|&&h| h).count(),
        colliding_edges: edge_hits.iter().filter(|&&h| h).count(),
        singular_waypoints: n0
            .iter()
            .filter(|n| singular::is_singular(**n, opts.alpha))
            .count(),
        breaks: 0,
        ..Metrics::default()
    };
    segment_stats(machine, &input_wp, &sections).finish(&mut input_m);
    input_m.axis_limit_violations = input_axes
        .iter()
        .filter(|a| metrics::outside_limits(machine, a))
        .count();
    for (w, h) in out.iter_mut().zip(&hit) {
        w.was_colliding = *h;
    }
    lap("metrics", &mut stages);
    Ok(Plan {
        waypoints: out,
        input: input_m,
        plan: plan_m,
        stages,
        input_axes,
        alpha: opts.alpha,
    })
}

/// Direct IK of the input: per waypoint the solution closest to the
/// previous one (the first: the smaller |C|), C unwound.
fn direct_ik(
    ctx: &Ctx,
    pos: &[[f64; 3]],
    n: &[[f64; 3]],
    sections: &[std::ops::Range<usize>],
) -> Vec<Axes> {
    let rot = ctx.machine.rotary;
    let mut out = vec![Axes::default(); pos.len()];
    for r in sections {
        let mut prev: Option<(f64, f64)> = None;
        for i in r.clone() {
            let s = ik_angles(rot, n[i]);
            let pick = match prev {
                None => {
                    if s[1].1.abs() < s[0].1.abs() {
                        s[1]
                    } else {
                        s[0]
                    }
                }
                Some((pt, pc)) => {
                    let cost = |x: (f64, f64)| (x.0 - pt).abs() + wrap(x.1 - pc).abs();
                    let best = if cost(s[1]) < cost(s[0]) { s[1] } else { s[0] };
                    (best.0, pc + wrap(best.1 - pc))
                }
            };
            prev = Some(pick);
            out[i] = ctx.axes(pos[i], pick);
        }
    }
    out
}

fn segment_stats(
    m: &Machine,
    w: &[PlannedWaypoint],
    sections: &[std::ops::Range<usize>],
) -> SegmentStats {
    let mut s = SegmentStats::default();
    for r in sections {
        for i in r.start + 1..r.end {
            if w[i].break_before {
                continue;
            }
            let (a, b) = (&w[i - 1], &w[i]);
            let len = (b.p[0] - a.p[0])
                .hypot(b.p[1] - a.p[1])
                .hypot(b.p[2] - a.p[2]);
            s.add(m, len, &a.axes, &b.axes);
        }
    }
    s
}

/// Layer height at each waypoint (Eq. 1's T): the distance to the nearest
/// waypoint of the previous layer; `default` on the first layer.
fn extrusion_heights(pos: &[[f64; 3]], layer_of: &[usize], default: f64) -> Vec<f64> {
    use rstar::RTree;
    let mut out = vec![default; pos.len()];
    let mut start = 0;
    let mut prev: Option<RTree<[f64; 3]>> = None;
    while start < pos.len() {
        let l = layer_of[start];
        let end = (start..pos.len())
            .find(|&i| layer_of[i] != l)
            .unwrap_or(pos.len());
        if let Some(tree) = &prev {
            out[start..end]
                .par_iter_mut()
                .enumerate()
                .for_each(|(k, h)| {
                    if let Some(q) = tree.nearest_neighbor(pos[start + k]) {
                        let p = pos[start + k];
                        let d = (p[0] - q[0]).hypot(p[1] - q[1]).hypot(p[2] - q[2]);
                        *h = d.clamp(0.05 * default, 4.0 * default);
                    }
                });
        }
        prev = Some(RTree::bulk_load(pos[start..end].to_vec()));
        start = end;
    }
    out
}
