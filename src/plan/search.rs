//! Stage 4, the graph search (paper 000, Algorithm 1): per section, the
//! cheapest path through the layered graph ([`graph`], priced by
//! [`cost`]) whose every node and printing move is proven free.
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

use super::columns::Status;
use super::*;
use rustc_hash::FxHashMap as HashMap;
use std::collections::{BTreeMap, BTreeSet};

/// A column where a node a path takes collided (or whose variants all did)
/// gets all its unchecked nodes asked at once after this many: columns
/// where the first choices fail tend to fail on, and a round per node
/// would make the search take as many rounds as the worst column has
/// variants.
const ASK_ALL_AFTER: u8 = 2;

/// What a section needs solved next: a repair of the windows around these
/// columns, or (`None`) the whole section.
type Redo = Option<Vec<usize>>;

/// What one round found to do on the open sections' paths.
#[derive(Default)]
struct Work {
    /// Unchecked nodes `(section, column, node, need)` (see
    /// [`State::check_nodes`]).
    asks: Vec<(usize, usize, usize, (f64, f64))>,
    /// Printing edges between nodes known free, not proven yet:
    /// `(section, key, waypoint)`.
    edges: Vec<(usize, (usize, usize, usize), usize)>,
    /// Sections with edges left for a later round (an end not known yet).
    waiting: Vec<usize>,
}

impl State<'_> {
    /// Stage 4: per section, the cheapest path whose nodes and printing
    /// moves are all proven free; then rotations the extruder cannot
    /// follow are spread ([`spread`]) and the sections that got new
    /// candidates solved again. Sections end in print order.
    pub(super) fn graph(&mut self, prover: &Prover) -> Result<(), PlanError> {
        // Sections: runs split at skipped waypoints.
        for r in &self.wp.runs {
            let mut start = r.start;
            for g in r.clone() {
                if self.skip[g].is_some() {
                    if start < g {
                        self.sections.push(start..g);
                    }
                    start = g + 1;
                }
            }
            if start < r.end {
                self.sections.push(start..r.end);
            }
        }
        let lens: Vec<f64> = (0..self.wp.pos.len())
            .map(|g| {
                self.wp
                    .pos
                    .get(g + 1)
                    .map_or(0.0, |q| dist(self.wp.pos[g], *q))
            })
            .collect();
        let mut models: Vec<CostModel> = self
            .sections
            .iter()
            .map(|r| self.cost_model(self.wp.layer_of[r.start]))
            .collect();
        let mut search = Search {
            edges: vec![Blocked::default(); self.sections.len()],
            paths: vec![Path::default(); self.sections.len()],
        };
        let all: Vec<usize> = (0..self.sections.len()).collect();
        self.solve(&mut search, &all, &lens, &mut models, prover)?;
        let changed = self.spread(&search.paths, &lens, &models, prover)?;
        if !changed.is_empty() {
            self.solve(&mut search, &changed, &lens, &mut models, prover)?;
        }
        // Every node a path visits was asked (the search's own invariant:
        // an unchecked pose must never reach the program).
        for (r, p) in self.sections.iter().zip(&search.paths) {
            for (k, g) in r.clone().enumerate() {
                if self.nodes[g][p.nodes[k]].status != Status::Free {
                    return Err(PlanError::Internal(format!(
                        "waypoint {g}'s planned configuration was never checked"
                    )));
                }
            }
        }
        // Sections split at waypoints skipped on the way were appended:
        // back to print order, the empty ones dropped.
        let mut both: Vec<(Range<usize>, Path)> = std::mem::take(&mut self.sections)
            .into_iter()
            .zip(search.paths)
            .filter(|(r, _)| !r.is_empty())
            .collect();
        both.sort_by_key(|(r, _)| r.start);
        (self.sections, self.paths) = both.into_iter().unzip();
        Ok(())
    }

    /// Solve sections `which` and prove their paths, round by round: the
    /// paths' unchecked nodes are asked and their printing moves between
    /// nodes known free proven; what fails dies or is blocked, and the
    /// windows around it are solved again ([`State::solve_paths`]), until
    /// every path is proven.
    fn solve(
        &mut self,
        search: &mut Search,
        which: &[usize],
        lens: &[f64],
        models: &mut Vec<CostModel>,
        prover: &Prover,
    ) -> Result<(), PlanError> {
        let mut redo: BTreeMap<usize, Redo> = which.iter().map(|&s| (s, None)).collect();
        let mut open: BTreeSet<usize> = which.iter().copied().collect();
        while !open.is_empty() {
            self.solve_paths(search, &redo, lens, models);
            redo.clear();
            let work = self.path_work(search, &open, prover);
            let wrong = |redo: &mut BTreeMap<usize, Redo>, s: usize, k: usize| {
                if let Some(cols) = redo.entry(s).or_insert(Some(Vec::new())) {
                    cols.push(k);
                }
            };
            // The nodes: the dead ones' columns refill, and a column with
            // nothing left gets the eager search.
            let mut skipped = Vec::new();
            if !work.asks.is_empty() {
                let asks: Vec<(usize, usize, (f64, f64))> = work
                    .asks
                    .iter()
                    .map(|&(s, k, j, need)| (self.sections[s].start + k, j, need))
                    .collect();
                let died = self.check_nodes(prover, &asks)?;
                let at: HashMap<usize, (usize, usize)> = work
                    .asks
                    .iter()
                    .map(|&(s, k, _, _)| (self.sections[s].start + k, (s, k)))
                    .collect();
                for &g in &died {
                    let (s, k) = at[&g];
                    wrong(&mut redo, s, k);
                }
                let empty = self.refill(&died);
                self.search_harder(prover, &empty)?;
                skipped.extend(empty.into_iter().filter(|&g| self.live_count(g) == 0));
            }
            // The printing moves between nodes known free (no column with
            // nothing left has one on a path).
            let per_edge: Vec<Vec<MoveSpec>> = work
                .edges
                .par_iter()
                .map(|&(_, key, g)| {
                    self.print_moves(g, &self.cols[g - 1][key.1], &self.cols[g][key.2])
                })
                .collect();
            let mut moves = Vec::new();
            let mut ranges = Vec::with_capacity(work.edges.len());
            for m in per_edge {
                let first = moves.len();
                moves.extend(m);
                ranges.push(first..moves.len());
            }
            let hits = prover.moves(&moves)?;
            for (&(s, key, _), range) in work.edges.iter().zip(ranges) {
                if hits[range].iter().any(|&h| h) {
                    search.edges[s].blocked.insert(key);
                    wrong(&mut redo, s, key.0);
                } else {
                    search.edges[s].proven.insert(key);
                }
            }
            // A waypoint with nothing at all is skipped, its section split.
            for g in skipped {
                self.skip[g] = Some(self.why_skipped(g));
                let s = (0..self.sections.len())
                    .find(|&s| self.sections[s].contains(&g))
                    .expect("a skipped waypoint lies in a section");
                let new = self.split(search, models, s, g);
                redo.insert(s, None);
                if let Some(t) = new {
                    redo.insert(t, None);
                }
            }
            open = redo.keys().copied().chain(work.waiting).collect();
        }
        Ok(())
    }

    /// New paths for the sections in `redo`: the whole section, or the
    /// windows around the columns where its path went wrong, widened from
    /// [`REPAIR_WINDOWS`]`[0]` to `[1]` when the repair needs more breaks
    /// than the path had, and replaced by a path through the whole section
    /// when that needs fewer breaks than the repair.
    fn solve_paths(
        &self,
        search: &mut Search,
        redo: &BTreeMap<usize, Redo>,
        lens: &[f64],
        models: &[CostModel],
    ) {
        let breaks = |p: &Path| p.breaks.iter().filter(|&&b| b).count();
        let todo: Vec<(&usize, &Redo)> = redo.iter().collect();
        let fresh: Vec<Path> = todo
            .par_iter()
            .map(|&(&s, cols)| {
                let r = self.sections[s].clone();
                let live = |i: usize, j: usize| self.live(r.start + i, j);
                let g = Columns {
                    cols: &self.cols[r.clone()],
                    lens: &lens[r.clone()],
                    cost: &models[s],
                    live: &live,
                };
                let edges = &search.edges[s];
                let full = || graph::shortest_path_subsampled(g, edges, self.opts.subsample);
                let Some(cols) = cols else {
                    return full();
                };
                let mut cols = cols.clone();
                cols.sort_unstable();
                cols.dedup();
                let old = &search.paths[s];
                let mut repaired = old.clone();
                for w in REPAIR_WINDOWS {
                    repaired = old.clone();
                    for win in windows(&cols, g.cols.len(), w) {
                        repaired = graph::repair(g, edges, &repaired, win);
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
            search.paths[s] = p;
        }
    }

    /// The open sections' unchecked path nodes (and, in a column that
    /// failed [`ASK_ALL_AFTER`] times, all its unchecked nodes), each with
    /// what the beads to its path neighbours need of it; and their
    /// printing edges between nodes known free that are not proven yet.
    fn path_work(&self, search: &Search, open: &BTreeSet<usize>, prover: &Prover) -> Work {
        let open: Vec<usize> = open.iter().copied().collect();
        let per: Vec<Work> = open
            .par_iter()
            .map(|&s| {
                let (r, p) = (&self.sections[s], &search.paths[s]);
                let mut w = Work::default();
                let status = |k: usize| self.nodes[r.start + k][p.nodes[k]].status;
                for k in 0..r.len() {
                    let g = r.start + k;
                    let node = p.nodes[k];
                    if status(k) != Status::Unknown {
                        continue;
                    }
                    // The beads this node's path prints to and from.
                    let a = self.cols[g][node];
                    let mut near = Vec::with_capacity(2);
                    if k > 0 && !p.breaks[k] {
                        near.push(self.cols[g - 1][p.nodes[k - 1]]);
                    }
                    if k + 1 < r.len() && !p.breaks[k + 1] {
                        near.push(self.cols[g + 1][p.nodes[k + 1]]);
                    }
                    let near: Vec<Axes> = near
                        .into_iter()
                        .map(|b| Axes {
                            c: self.unwound(a.c, b.c),
                            ..b
                        })
                        .collect();
                    if self.misses[g] >= ASK_ALL_AFTER {
                        for (j, n) in self.nodes[g].iter().enumerate() {
                            if n.status == Status::Unknown {
                                let need = prover.end_need(&self.cols[g][j], &near);
                                w.asks.push((s, k, j, need));
                            }
                        }
                    } else {
                        w.asks.push((s, k, node, prover.end_need(&a, &near)));
                    }
                }
                let known = &search.edges[s];
                for k in 1..r.len() {
                    if p.breaks[k] {
                        continue;
                    }
                    let key = (k, p.nodes[k - 1], p.nodes[k]);
                    if known.proven.contains(&key) || known.blocked.contains(&key) {
                        continue;
                    }
                    if status(k - 1) != Status::Free || status(k) != Status::Free {
                        if w.waiting.is_empty() {
                            w.waiting.push(s);
                        }
                        continue;
                    }
                    w.edges.push((s, key, r.start + k));
                }
                w
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

    /// Split section `s` at waypoint `g`, which is skipped: `s` keeps the
    /// waypoints before it (or, when there are none, the ones after), a new
    /// section takes the ones after. Returns the new section's index.
    fn split(
        &mut self,
        search: &mut Search,
        models: &mut Vec<CostModel>,
        s: usize,
        g: usize,
    ) -> Option<usize> {
        let r = self.sections[s].clone();
        let (before, after) = (r.start..g, g + 1..r.end);
        search.paths[s] = Path::default();
        if before.is_empty() {
            // Column indices move: what was learnt of the edges is dropped
            // (the prover remembers every move's verdict).
            search.edges[s] = Blocked::default();
            self.sections[s] = if after.is_empty() { g..g } else { after };
            return None;
        }
        self.sections[s] = before;
        if after.is_empty() {
            return None;
        }
        let model = self.cost_model(self.wp.layer_of[after.start]);
        self.sections.push(after);
        models.push(model);
        search.edges.push(Blocked::default());
        search.paths.push(Path::default());
        Some(self.sections.len() - 1)
    }

    /// Offer C values that spread too-fast turns ([`spread`]) as extra
    /// candidates where they are feasible and free. Returns the sections
    /// that got any.
    fn spread(
        &mut self,
        paths: &[Path],
        lens: &[f64],
        models: &[CostModel],
        prover: &Prover,
    ) -> Result<Vec<usize>, PlanError> {
        let tol = self.opts.spread_tolerance;
        let mut offers: Vec<(usize, usize, Axes)> = Vec::new();
        for (s, r) in self.sections.iter().enumerate() {
            let (p, cm) = (&paths[s], &models[s]);
            let cfg: Vec<Axes> = r
                .clone()
                .enumerate()
                .map(|(k, g)| self.cols[g][p.nodes[k]])
                .collect();
            // Printed runs between breaks.
            let mut k0 = 0;
            for k in 1..=r.len() {
                if k < r.len() && !p.breaks[k] {
                    continue;
                }
                let run = k0..k;
                k0 = k;
                let slow = run
                    .clone()
                    .skip(1)
                    .any(|j| cm.dwell(lens[r.start + j - 1], &cfg[j - 1], &cfg[j]) > 0.0);
                if run.len() < 2 || !slow {
                    continue;
                }
                let mut target = Vec::with_capacity(run.len());
                for j in run.clone() {
                    let prev = target.last().copied().unwrap_or(cfg[j].c);
                    target.push(prev + cm.winding.dc(prev, cfg[j].c));
                }
                // Each bead's time at the slowest tip speed, less room for
                // the program's rounding: the written bead may be up to
                // ROUNDING_MM shorter, each angle 0.001° off.
                let budget = |j: usize, speed: f64| {
                    let len = if j > 0 { lens[r.start + j - 1] } else { 0.0 };
                    let len = (len - ROUNDING_MM).max(0.0);
                    ((speed * len / cm.tip_speed[0]) * (1.0 - 1e-3) - 0.002)
                        .max(0.0)
                        .to_radians()
                };
                // C first, within the whole tolerance; then the tilt, within
                // what C left of it.
                let tube: Vec<f64> = run
                    .clone()
                    .map(|j| spread::c_tube(cfg[j].tilt, tol))
                    .collect();
                let rate: Vec<f64> = run.clone().map(|j| budget(j, cm.rotary[1])).collect();
                let c = spread::rate_limited(&target, &tube, &rate);
                let tilts: Vec<f64> = run.clone().map(|j| cfg[j].tilt).collect();
                let t_tube: Vec<f64> = run
                    .clone()
                    .enumerate()
                    .map(|(i, j)| {
                        (tol - spread::c_deviation(cfg[j].tilt, c[i] - target[i])).max(0.0)
                    })
                    .collect();
                let t_rate: Vec<f64> = run.clone().map(|j| budget(j, cm.rotary[0])).collect();
                let t = spread::rate_limited(&tilts, &t_tube, &t_rate);
                for (i, j) in run.enumerate() {
                    if (c[i] - target[i]).abs() > 1e-5 || (t[i] - tilts[i]).abs() > 1e-5 {
                        let cc = match cm.winding {
                            Winding::Free => wrap(c[i]),
                            Winding::Absolute => c[i],
                        };
                        let in_range = self
                            .machine
                            .c
                            .range
                            .is_none_or(|[lo, hi]| (lo..=hi).contains(&c[i].to_degrees()));
                        if let Some(a) = self.feasible(r.start + j, (t[i], cc)) {
                            if in_range {
                                offers.push((s, r.start + j, a));
                            }
                        }
                    }
                }
            }
        }
        let items: Vec<(Axes, u32)> = offers.iter().map(|&(_, g, a)| (a, cutoff(g))).collect();
        let hits = prover.poses(&items)?;
        let mut changed = Vec::new();
        for ((s, g, a), hit) in offers.into_iter().zip(hits) {
            if !hit && self.push_free(g, a) && changed.last() != Some(&s) {
                changed.push(s);
            }
        }
        Ok(changed)
    }
}
