//! Stage 4, the graph search (paper 000, Algorithm 1): per section, the
//! cheapest path through the layered graph ([`shortest_path`], priced by
//! [`super::cost`]) whose every node and printing move is proven free.
//!
//! The search is lazy on both counts. A path may take unchecked nodes
//! (variants, [`super::columns`]); each round asks the nodes its paths
//! took (wide enough for the beads to their path neighbours) and proves
//! the printing moves between nodes known free. A node that collides
//! dies, a move that cannot be proven is blocked, and only a window of
//! [`REPAIR_WINDOWS`] columns around each is solved again (the rest of
//! the path stands); the whole section only when that needs fewer
//! breaks than the repair. A column whose variants all die gets the
//! eager search; a waypoint left with nothing is skipped and its section
//! split in two. Then rotations the extruder cannot follow are spread
//! ([`spread`]) and the sections that got new candidates solved again.

use super::columns::{Columns, Status};
use super::cost::{CostModel, Winding};
use super::setup::distance;
use super::shortest_path::{self, KnownEdges, Path, SectionGraph};
use super::{spread, PlanError, Skip};
use crate::kinematics::{wrap, Axes};
use crate::prove::{pieces_bound, MoveSpec, Prover};
use crate::scene::cutoff;
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;

/// Columns on either side of a blocked edge that are solved again, tried
/// in turn: a small window first (few new edges to prove), a larger one
/// when routing around the block needs more breaks than the path had.
pub const REPAIR_WINDOWS: [usize; 2] = [4, 32];

/// A column where a node a path takes collided (or whose variants all did)
/// gets all its unchecked nodes asked at once after this many: columns
/// where the first choices fail tend to fail on, and a round per node
/// would make the search take as many rounds as the worst column has
/// variants.
const ASK_ALL_AFTER: u8 = 2;

/// One section of the route: consecutive waypoints of a run, printed one
/// after the other but where a break is priced cheaper.
pub(super) struct Section {
    /// Its waypoints (global indices), in print order.
    pub waypoints: Range<usize>,
    /// The configuration its path takes at each waypoint.
    pub axes: Vec<Axes>,
    /// `breaks[k]`: its `k`-th waypoint is entered through a break (never
    /// the first).
    pub breaks: Vec<bool>,
}

/// Stage 4's result: the sections in print order, and the waypoints not
/// visited.
pub(super) struct Route {
    /// The sections, in print order.
    pub sections: Vec<Section>,
    /// Per waypoint: not visited, and why.
    pub skip: Vec<Option<Skip>>,
}

/// Stage 4: per section, the cheapest path whose nodes and printing
/// moves are all proven free; then rotations the extruder cannot
/// follow are spread ([`spread`]) and the sections that got new
/// candidates solved again. Waypoints with no printed bead on either side
/// are not visited ([`Skip::Isolated`]).
pub(super) fn route(columns: Columns, prover: &Prover) -> Result<Route, PlanError> {
    let mut search = Search::new(columns);
    let all: Vec<usize> = (0..search.sections.len()).collect();
    search.solve(&all, prover)?;
    let base = search.columns.setup.opts.spread_tolerance;
    for widen in SPREAD_WIDENING {
        let changed = search.spread(prover, base * widen)?;
        if changed.is_empty() {
            break;
        }
        search.solve(&changed, prover)?;
    }
    search.into_route()
}

/// The spread's tolerance, as multiples of [`super::PlanOptions::spread_tolerance`],
/// tried in turn while rotations the extruder cannot follow remain: a
/// turn too fast for the waypoints around it to absorb within the first
/// (a single waypoint whose own orientation collides, its neighbours' not)
/// is spread over a wider tube.
const SPREAD_WIDENING: [f64; 3] = [1.0, 2.0, 4.0];

/// What a section needs solved next: a repair of the windows around these
/// columns, or (`None`) the whole section.
type Redo = Option<Vec<usize>>;

/// Section `s` needs its path repaired around its column `k`.
fn redo_around(redo: &mut BTreeMap<usize, Redo>, s: usize, k: usize) {
    if let Some(cols) = redo.entry(s).or_insert(Some(Vec::new())) {
        cols.push(k);
    }
}

/// An unchecked node a path takes: `(section, column, node, need)`, with
/// what the beads to its path neighbours need of it ([`Prover::end_need`]).
type Ask = (usize, usize, usize, (f64, f64));

/// A printing edge between nodes known free, not proven yet:
/// `(section, key, waypoint)`, its key as [`KnownEdges`] holds it.
type Edge = (usize, (usize, usize, usize), usize);

/// What one round found to do on the open sections' paths.
#[derive(Default)]
struct Work {
    /// Unchecked nodes to ask.
    asks: Vec<Ask>,
    /// Printing edges to prove.
    edges: Vec<Edge>,
    /// Sections with edges left for a later round (an end not known yet).
    waiting: Vec<usize>,
}

/// The search's state: the columns it goes on refining, and per section
/// its path and what is known of its printing edges.
struct Search<'a> {
    columns: Columns<'a>,
    /// Runs split at skipped waypoints; a section split on the way keeps
    /// its first part and the rest is appended.
    sections: Vec<Range<usize>>,
    /// Per section: its path.
    paths: Vec<Path>,
    /// Per section: what is known of its printing edges.
    edges: Vec<KnownEdges>,
    /// Per section: the costs of printing its layer.
    models: Vec<CostModel>,
    /// `lens[g]`: the bead length from waypoint `g` to `g + 1` (0 for the
    /// last).
    lens: Vec<f64>,
}

impl<'a> Search<'a> {
    /// The sections (runs split at the waypoints the columns skipped),
    /// none solved yet.
    fn new(columns: Columns<'a>) -> Self {
        let setup = columns.setup;
        let pos = &setup.toolpath.pos;
        let mut sections = Vec::new();
        for r in &setup.toolpath.runs {
            let mut start = r.start;
            for g in r.clone() {
                if columns.skip[g].is_some() {
                    if start < g {
                        sections.push(start..g);
                    }
                    start = g + 1;
                }
            }
            if start < r.end {
                sections.push(start..r.end);
            }
        }
        let lens: Vec<f64> = (0..pos.len())
            .map(|g| pos.get(g + 1).map_or(0.0, |q| distance(pos[g], *q)))
            .collect();
        let models = sections
            .iter()
            .map(|r| setup.cost_model(setup.toolpath.layer_of[r.start]))
            .collect();
        Search {
            edges: vec![KnownEdges::default(); sections.len()],
            paths: vec![Path::default(); sections.len()],
            columns,
            sections,
            models,
            lens,
        }
    }

    /// Solve sections `which` and prove their paths, round by round: the
    /// paths' unchecked nodes are asked and their printing moves between
    /// nodes known free proven; what fails dies or is blocked, and the
    /// windows around it are solved again ([`Search::solve_paths`]), until
    /// every path is proven.
    fn solve(&mut self, which: &[usize], prover: &Prover) -> Result<(), PlanError> {
        let mut redo: BTreeMap<usize, Redo> = which.iter().map(|&s| (s, None)).collect();
        let mut open: BTreeSet<usize> = which.iter().copied().collect();
        while !open.is_empty() {
            self.solve_paths(&redo);
            redo.clear();
            let work = self.path_work(&open, prover);
            let skipped = self.ask_nodes(&work.asks, &mut redo, prover)?;
            self.prove_edges(&work.edges, &mut redo, prover)?;
            for g in skipped {
                self.skip_and_split(g, &mut redo);
            }
            open = redo.keys().copied().chain(work.waiting).collect();
        }
        Ok(())
    }

    /// Ask the nodes `asks`: the dead ones' sections are repaired around
    /// them and their columns refill, and a column with nothing left gets
    /// the eager search. Returns the waypoints left with nothing at all.
    fn ask_nodes(
        &mut self,
        asks: &[Ask],
        redo: &mut BTreeMap<usize, Redo>,
        prover: &Prover,
    ) -> Result<Vec<usize>, PlanError> {
        if asks.is_empty() {
            return Ok(Vec::new());
        }
        let at_waypoint: Vec<(usize, usize, (f64, f64))> = asks
            .iter()
            .map(|&(s, k, j, need)| (self.sections[s].start + k, j, need))
            .collect();
        let died = self.columns.check_nodes(prover, &at_waypoint)?;
        let column_of: HashMap<usize, (usize, usize)> = asks
            .iter()
            .map(|&(s, k, _, _)| (self.sections[s].start + k, (s, k)))
            .collect();
        for &g in &died {
            let (s, k) = column_of[&g];
            redo_around(redo, s, k);
        }
        let empty = self.columns.refill(&died);
        self.columns.search_harder(prover, &empty)?;
        Ok(empty
            .into_iter()
            .filter(|&g| self.columns.live_count(g) == 0)
            .collect())
    }

    /// Prove the printing moves of `edges` (no column with nothing left
    /// has one on a path): each is proven or blocked, and a blocked one's
    /// section repaired around it.
    fn prove_edges(
        &mut self,
        edges: &[Edge],
        redo: &mut BTreeMap<usize, Redo>,
        prover: &Prover,
    ) -> Result<(), PlanError> {
        let (setup, configs) = (self.columns.setup, &self.columns.configs);
        let per_edge: Vec<Vec<MoveSpec>> = edges
            .par_iter()
            .map(|&(_, key, g)| setup.print_moves(g, &configs[g - 1][key.1], &configs[g][key.2]))
            .collect();
        let mut moves = Vec::new();
        let mut ranges = Vec::with_capacity(edges.len());
        for m in per_edge {
            let first = moves.len();
            moves.extend(m);
            ranges.push(first..moves.len());
        }
        let hits = prover.moves(&moves)?;
        for (&(s, key, _), range) in edges.iter().zip(ranges) {
            if hits[range].iter().any(|&h| h) {
                self.edges[s].blocked.insert(key);
                redo_around(redo, s, key.0);
            } else {
                self.edges[s].proven.insert(key);
            }
        }
        Ok(())
    }

    /// Skip waypoint `g`, which has nothing at all, and split its section
    /// there; both parts are solved again.
    fn skip_and_split(&mut self, g: usize, redo: &mut BTreeMap<usize, Redo>) {
        self.columns.skip[g] = Some(self.columns.why_skipped(g));
        let s = (0..self.sections.len())
            .find(|&s| self.sections[s].contains(&g))
            .expect("a skipped waypoint lies in a section");
        let new = self.split(s, g);
        redo.insert(s, None);
        if let Some(t) = new {
            redo.insert(t, None);
        }
    }

    /// New paths for the sections in `redo`: the whole section, or the
    /// windows around the columns where its path went wrong, widened from
    /// [`REPAIR_WINDOWS`]`[0]` to `[1]` when the repair needs more breaks
    /// than the path had, and replaced by a path through the whole section
    /// when that needs fewer breaks than the repair.
    fn solve_paths(&mut self, redo: &BTreeMap<usize, Redo>) {
        let breaks = |p: &Path| p.breaks.iter().filter(|&&b| b).count();
        let todo: Vec<(&usize, &Redo)> = redo.iter().collect();
        let subsample = self.columns.setup.opts.subsample;
        let fresh: Vec<Path> = todo
            .par_iter()
            .map(|&(&s, cols)| {
                let r = self.sections[s].clone();
                let live = |i: usize, j: usize| self.columns.live(r.start + i, j);
                let g = SectionGraph {
                    configs: &self.columns.configs[r.clone()],
                    lens: &self.lens[r.clone()],
                    cost: &self.models[s],
                    live: &live,
                };
                let edges = &self.edges[s];
                let full = || shortest_path::shortest_path_subsampled(g, edges, subsample);
                let Some(cols) = cols else {
                    return full();
                };
                let mut cols = cols.clone();
                cols.sort_unstable();
                cols.dedup();
                let old = &self.paths[s];
                let mut repaired = old.clone();
                for w in REPAIR_WINDOWS {
                    repaired = old.clone();
                    for win in windows(&cols, g.configs.len(), w) {
                        repaired = shortest_path::repair(g, edges, &repaired, win);
                    }
                    if breaks(&repaired) <= breaks(old) {
                        return repaired;
                    }
                }
                // The block costs a break: keep the repair unless a new
                // path through the whole section needs fewer.
                let fresh = full();
                if breaks(&fresh) < breaks(&repaired) {
                    fresh
                } else {
                    repaired
                }
            })
            .collect();
        for ((&s, _), p) in todo.into_iter().zip(fresh) {
            self.paths[s] = p;
        }
    }

    /// The open sections' unchecked path nodes (and, in a column that
    /// failed [`ASK_ALL_AFTER`] times, all its unchecked nodes), each with
    /// what the beads to its path neighbours need of it; and their
    /// printing edges between nodes known free that are not proven yet.
    fn path_work(&self, open: &BTreeSet<usize>, prover: &Prover) -> Work {
        let open: Vec<usize> = open.iter().copied().collect();
        let per: Vec<Work> = open
            .par_iter()
            .map(|&s| {
                let (edges, waiting) = self.path_edges(s);
                Work {
                    asks: self.path_asks(s, prover),
                    edges,
                    waiting: if waiting { vec![s] } else { Vec::new() },
                }
            })
            .collect();
        let mut all = Work::default();
        for w in per {
            all.asks.extend(w.asks);
            all.edges.extend(w.edges);
            all.waiting.extend(w.waiting);
        }
        all
    }

    /// Section `s`'s printing edges between nodes known free that are not
    /// proven yet, and whether it has edges left for a later round (an
    /// end not known yet).
    fn path_edges(&self, s: usize) -> (Vec<Edge>, bool) {
        let (r, p) = (&self.sections[s], &self.paths[s]);
        let status = |k: usize| self.columns.nodes[r.start + k][p.nodes[k]].status;
        let known = &self.edges[s];
        let mut edges = Vec::new();
        let mut waiting = false;
        for k in 1..r.len() {
            if p.breaks[k] {
                continue;
            }
            let key = (k, p.nodes[k - 1], p.nodes[k]);
            if known.proven.contains(&key) || known.blocked.contains(&key) {
                continue;
            }
            if status(k - 1) != Status::Free || status(k) != Status::Free {
                waiting = true;
                continue;
            }
            edges.push((s, key, r.start + k));
        }
        (edges, waiting)
    }

    /// Section `s`'s unchecked path nodes (and, in a column that failed
    /// [`ASK_ALL_AFTER`] times, all its unchecked nodes), each with what
    /// the beads to its path neighbours need of it.
    fn path_asks(&self, s: usize, prover: &Prover) -> Vec<Ask> {
        let (r, p) = (&self.sections[s], &self.paths[s]);
        let (columns, setup) = (&self.columns, self.columns.setup);
        let mut asks = Vec::new();
        for k in 0..r.len() {
            let g = r.start + k;
            let node = p.nodes[k];
            if columns.nodes[g][node].status != Status::Unknown {
                continue;
            }
            // The beads this node's path prints to and from.
            let a = columns.configs[g][node];
            let mut near = Vec::with_capacity(2);
            if k > 0 && !p.breaks[k] {
                near.push(columns.configs[g - 1][p.nodes[k - 1]]);
            }
            if k + 1 < r.len() && !p.breaks[k + 1] {
                near.push(columns.configs[g + 1][p.nodes[k + 1]]);
            }
            let near: Vec<Axes> = near
                .into_iter()
                .map(|b| Axes {
                    c: setup.unwound(a.c, b.c),
                    ..b
                })
                .collect();
            if columns.misses[g] >= ASK_ALL_AFTER {
                for (j, n) in columns.nodes[g].iter().enumerate() {
                    if n.status == Status::Unknown {
                        let need = prover.end_need(&columns.configs[g][j], &near);
                        asks.push((s, k, j, need));
                    }
                }
            } else {
                asks.push((s, k, node, prover.end_need(&a, &near)));
            }
        }
        asks
    }

    /// Split section `s` at waypoint `g`, which is skipped: `s` keeps the
    /// waypoints before it (or, when there are none, the ones after), a new
    /// section takes the ones after. Returns the new section's index.
    fn split(&mut self, s: usize, g: usize) -> Option<usize> {
        let r = self.sections[s].clone();
        let (before, after) = (r.start..g, g + 1..r.end);
        self.paths[s] = Path::default();
        if before.is_empty() {
            // Column indices move: what was learnt of the edges is dropped
            // (the prover remembers every move's verdict).
            self.edges[s] = KnownEdges::default();
            self.sections[s] = if after.is_empty() { g..g } else { after };
            return None;
        }
        self.sections[s] = before;
        if after.is_empty() {
            return None;
        }
        let setup = self.columns.setup;
        let model = setup.cost_model(setup.toolpath.layer_of[after.start]);
        self.sections.push(after);
        self.models.push(model);
        self.edges.push(KnownEdges::default());
        self.paths.push(Path::default());
        Some(self.sections.len() - 1)
    }

    /// Offer C values that spread too-fast turns ([`spread`]) as extra
    /// candidates where they are feasible and free. Returns the sections
    /// that got any.
    fn spread(&mut self, prover: &Prover, tol: f64) -> Result<Vec<usize>, PlanError> {
        let offers = self.spread_offers(tol);
        let items: Vec<(Axes, u32)> = offers.iter().map(|&(_, g, a)| (a, cutoff(g))).collect();
        let hits = prover.poses(&items)?;
        let mut changed = Vec::new();
        for ((s, g, a), hit) in offers.into_iter().zip(hits) {
            if !hit && self.columns.push_free(g, a) && changed.last() != Some(&s) {
                changed.push(s);
            }
        }
        Ok(changed)
    }

    /// The configurations that spread the too-fast turns of every printed
    /// run of the paths ([`spread::spread_run`]), where they are feasible
    /// and C within its range: `(section, waypoint, axes)`.
    fn spread_offers(&self, tol: f64) -> Vec<(usize, usize, Axes)> {
        let setup = self.columns.setup;
        let mut offers = Vec::new();
        for (s, r) in self.sections.iter().enumerate() {
            let (p, cm) = (&self.paths[s], &self.models[s]);
            let cfg: Vec<Axes> = r
                .clone()
                .enumerate()
                .map(|(k, g)| self.columns.configs[g][p.nodes[k]])
                .collect();
            for run in printed_runs(&p.breaks) {
                // The bead into each waypoint of the run (none into the
                // section's first).
                let bead_in: Vec<f64> = run
                    .clone()
                    .map(|j| {
                        if j > 0 {
                            self.lens[r.start + j - 1]
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let m = setup.machine;
                let run_cfg = &cfg[run.clone()];
                let pieces = |i: usize, turn: f64| {
                    let reach = (DVec3::from(m.tip(&run_cfg[i])).length())
                        .max(DVec3::from(m.tip(&run_cfg[i.saturating_sub(1)])).length());
                    pieces_bound(m, reach, bead_in[i], turn, m.tip_tolerance)
                };
                let spread = spread::spread_run(run_cfg, &bead_in, cm, tol, pieces);
                for (i, tilt, c) in spread {
                    let g = r.start + run.start + i;
                    let as_written = match cm.winding {
                        Winding::Free => wrap(c),
                        Winding::Absolute => c,
                    };
                    let in_range = setup
                        .machine
                        .c
                        .range
                        .is_none_or(|[lo, hi]| (lo..=hi).contains(&c.to_degrees()));
                    if let Some(a) = setup.feasible(g, (tilt, as_written)) {
                        if in_range {
                            offers.push((s, g, a));
                        }
                    }
                }
            }
        }
        offers
    }

    /// The route: every path checked to visit only nodes asked free (an
    /// unchecked pose must never reach the program), the sections back in
    /// print order with the configurations their paths take, and the
    /// waypoints with no bead on either side not visited.
    fn into_route(self) -> Result<Route, PlanError> {
        let Search {
            columns,
            sections,
            paths,
            ..
        } = self;
        for (r, p) in sections.iter().zip(&paths) {
            for (k, g) in r.clone().enumerate() {
                if columns.nodes[g][p.nodes[k]].status != Status::Free {
                    return Err(PlanError::Internal(format!(
                        "waypoint {g}'s planned configuration was never checked"
                    )));
                }
            }
        }
        // Sections split at waypoints skipped on the way were appended:
        // back to print order, the empty ones dropped.
        let mut both: Vec<(Range<usize>, Path)> = sections
            .into_iter()
            .zip(paths)
            .filter(|(r, _)| !r.is_empty())
            .collect();
        both.sort_by_key(|(r, _)| r.start);
        let sections: Vec<Section> = both
            .into_iter()
            .map(|(r, p)| Section {
                axes: r
                    .clone()
                    .enumerate()
                    .map(|(k, g)| columns.configs[g][p.nodes[k]])
                    .collect(),
                breaks: p.breaks,
                waypoints: r,
            })
            .collect();
        let mut skip = columns.skip;
        for sec in &sections {
            let n = sec.waypoints.len();
            for (k, g) in sec.waypoints.clone().enumerate() {
                let bead_in = k > 0 && !sec.breaks[k];
                let bead_out = k + 1 < n && !sec.breaks[k + 1];
                if !bead_in && !bead_out {
                    skip[g] = Some(Skip::Isolated);
                }
            }
        }
        Ok(Route { sections, skip })
    }
}

/// The printed runs of a path whose moves into each column are
/// `breaks`: the column ranges between breaks.
fn printed_runs(breaks: &[bool]) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut start = 0;
    for k in 1..=breaks.len() {
        if k < breaks.len() && !breaks[k] {
            continue;
        }
        runs.push(start..k);
        start = k;
    }
    runs
}

/// Merged windows of `w` columns on either side of `cols` (sorted) in a
/// section of `n` columns.
fn windows(cols: &[usize], n: usize, w: usize) -> Vec<Range<usize>> {
    let mut out: Vec<Range<usize>> = Vec::new();
    for &k in cols {
        let r = k.saturating_sub(w)..(k + w).min(n);
        match out.last_mut() {
            Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
            _ => out.push(r),
        }
    }
    out
}
