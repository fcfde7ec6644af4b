//! Stage 3, the columns: per waypoint, the machine configurations the
//! graph search may visit (paper 000, Sec. III-A), and what is known of
//! each one's pose ([`Status`]).
//!
//! A waypoint whose own orientation is free gets its IK solutions,
//! asked at once and wide enough that the beads to its neighbours start
//! proven ([`Prover::poses_wide`]): that is most waypoints. One whose own
//! orientation collides gets variants ([`candidates`]), and those are
//! *not* asked here: its column is a window of at most `max_configs`
//! unchecked nodes over its first round of variants, in their order, and
//! the search asks a node only when its path takes it
//! ([`super::graph`]). A node found colliding stays in its column (so
//! node indices keep their meaning) but dies, and the next variant enters
//! the window. A column whose first round dies out gets the eager search
//! ([`Columns::search_harder`]): the free orientations of its neighbours
//! (where every variant near a waypoint's own orientation collides, they
//! lie far out, and its neighbours found them already), then wider
//! rounds, then every reachable orientation in shells, asked until the
//! column holds a free configuration; a waypoint with none is skipped.
//!
//! Clearance first: a waypoint whose own orientation falls short of what
//! its beads need of it gets variants as if it collided, whether it
//! collides or only grazes (free at the pose margin, its beads proven
//! sample by sample down to `min_step`, no room to spare). Its own
//! configuration is kept aside ([`Status::Tight`]) and asked like a
//! variant only when the column has nothing else left, before the eager
//! search. Variants are taken as they come, grazing or not.
//!
//! Why lazily: where most waypoints collide as given, asking every variant
//! of every column costs a query per variant to keep up to `max_configs`
//! free configurations each, of which the path takes one.

mod eager;

use super::candidates;
use super::memory::release_freed_memory;
use super::setup::{windings, Setup};
use super::{PlanError, Skip};
use crate::kinematics::{ik_angles, orientation, Axes};
use crate::prove::Prover;
use crate::scene::cutoff;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use std::ops::Range;

/// What is known of a node's pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Status {
    /// Free at the pose margin.
    Free,
    /// Not asked yet: asked when a path takes it.
    Unknown,
    /// Not asked yet, and the same variant collides at a neighbouring
    /// probe ([`PROBE_EVERY`]): kept off paths while its column has
    /// anything else.
    Unlikely,
    /// Within the pose margin of material: never on a path.
    Hit,
    /// A waypoint's own configuration that falls short of what the beads
    /// to its neighbours need of it ([`Prover::poses_short_of_need`]: it
    /// grazes or collides, and is not asked at the pose margin): its
    /// waypoint gets variants as if it collided, and it stays off paths
    /// while its column has anything else. When the column runs out of
    /// variants it becomes [`Status::Unknown`] (asked, like a variant, when
    /// a path takes it), before the eager search.
    Tight,
}

/// In a run of waypoints whose own orientations collide, every this many
/// (and the run's ends) is a *probe*: its whole first round of variants
/// is asked. Every waypoint offers the same pattern of variants around
/// its own orientation, so a variant free at the probes on either side
/// of a waypoint is likely free there too, and one that collides at
/// either is likely to collide (the path's cheapest variants are the ones
/// nearest the colliding input, and without probes most of the nodes the
/// paths take would collide, round after round). A probe costs its whole
/// first round; the variants between are asked lazily anyway, so a wrong
/// guess costs a query later, not a wrong plan. Denser probes ask more
/// than they save; sparser ones guess worse for little gain.
pub(super) const PROBE_EVERY: usize = 16;

/// Variants per waypoint a probe can vouch for: their IK solutions are
/// bits of a `u128` (bit `2 · item + solution`); later ones are taken as
/// plausible.
const PROBED_ITEMS: usize = 64;

/// A node of a column, beside its configuration in [`Columns::configs`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Node {
    /// What is known of its pose.
    pub status: Status,
    /// Which of the column's poses it is: nodes of one configuration (C's
    /// windings under a C range; a half-turn-symmetric head's two IK
    /// solutions) share the pose and its verdict.
    pub pose: u32,
    /// Counted against `max_configs` (further windings of one
    /// configuration are not: the cap counts configurations, not turns).
    pub counted: bool,
}

/// The cursor of a column with no variants left to enter its window.
pub(super) const EXHAUSTED: u32 = u32::MAX;

/// The probes among `n` neighbouring waypoints, by position: the ends and
/// every [`PROBE_EVERY`]-th.
fn probe_positions(n: usize) -> Vec<usize> {
    let mut at: Vec<usize> = (0..n).step_by(PROBE_EVERY).collect();
    if n > 0 && !(n - 1).is_multiple_of(PROBE_EVERY) {
        at.push(n - 1);
    }
    at
}

/// A variant about to enter a column: the number of its item in the
/// waypoint's first round, its configuration, and the status it enters
/// with.
type Next = (u32, Axes, Status);

/// The feasible configurations of an IK pair `[solution, mirror]`, at
/// most two, held in place: an offer makes one per item, millions in a
/// steep part's eager search, where a vector each was an allocation made
/// on every core and freed on one.
#[derive(Clone, Copy)]
pub(super) struct Feasible {
    axes: [Axes; 2],
    len: u8,
}

impl Feasible {
    /// The configurations of `pair` that are `Some`, in order.
    fn of(pair: [Option<Axes>; 2]) -> Self {
        let mut f = Feasible {
            axes: [Axes::default(); 2],
            len: 0,
        };
        for a in pair.into_iter().flatten() {
            f.axes[f.len as usize] = a;
            f.len += 1;
        }
        f
    }

    /// Each configuration after the first, at `cutoff`, with the first:
    /// the same head geometry turned by the head's half-turn symmetry
    /// ([`Prover::same_as_each`]).
    fn mirrors(&self, cutoff: u32) -> impl Iterator<Item = (Axes, u32, Axes)> + '_ {
        self.iter().skip(1).map(move |a| (*a, cutoff, self[0]))
    }
}

impl std::ops::Deref for Feasible {
    type Target = [Axes];
    fn deref(&self) -> &[Axes] {
        &self.axes[..self.len as usize]
    }
}

/// Waypoints whose next configurations [`Columns::refill`] finds at once.
const REFILL_BLOCK: usize = 1 << 14;

/// Stage 3's columns, which stage 4 goes on filling as it learns: per
/// waypoint its candidate configurations and what is known of each, and
/// what the lazy filling needs to go on.
pub(super) struct Columns<'a> {
    pub setup: &'a Setup<'a>,
    /// Per waypoint: its candidate configurations (as written).
    pub configs: Vec<Vec<Axes>>,
    /// Beside each configuration, its node: what is known of its pose.
    pub nodes: Vec<Vec<Node>>,
    /// Per waypoint: the next of its first round of variants to enter its
    /// window ([`EXHAUSTED`]: none).
    cursor: Vec<u32>,
    /// Per waypoint: how often a node its path took collided.
    pub misses: Vec<u8>,
    /// Per colliding waypoint: its first-round variants (bit
    /// `2 · item + solution`) free at a probe — a probe's own, or those
    /// free at both probes around it.
    free_at: Vec<u128>,
    /// Per waypoint: it is a probe ([`PROBE_EVERY`]).
    probed: Vec<bool>,
    /// Per waypoint: some configuration offered was in the machine's
    /// ranges.
    offered: Vec<bool>,
    /// Per waypoint: the orientation it is planned around.
    centre: Vec<[f64; 3]>,
    /// Per waypoint: not visited, and why.
    pub skip: Vec<Option<Skip>>,
}

impl<'a> Columns<'a> {
    /// May node `j` of waypoint `g`'s column be on a path?
    pub(super) fn live(&self, g: usize, j: usize) -> bool {
        matches!(self.nodes[g][j].status, Status::Free | Status::Unknown)
    }

    /// Live nodes of waypoint `g`'s column counted against the cap.
    pub(super) fn live_count(&self, g: usize) -> usize {
        self.nodes[g]
            .iter()
            .enumerate()
            .filter(|&(j, n)| n.counted && self.live(g, j))
            .count()
    }

    /// The pose number a configuration new to waypoint `g`'s column takes.
    fn next_pose(&self, g: usize) -> u32 {
        self.nodes[g].last().map_or(0, |n| n.pose + 1)
    }

    /// Add configuration `a` to waypoint `g`'s column as pose `pose` (under
    /// a C range: one node per whole turn of C inside it), unless the
    /// column holds it already. Returns whether it was added.
    fn push_config(&mut self, g: usize, a: Axes, status: Status, pose: u32) -> bool {
        // (Without a C range, `a`'s own C and no list: a list per
        // configuration would be an allocation per configuration.)
        let turns = self.setup.machine.c.range.map(|range| windings(a.c, range));
        let all = turns.as_deref().unwrap_or(std::slice::from_ref(&a.c));
        if all
            .first()
            .is_none_or(|&c| self.configs[g].contains(&Axes { c, ..a }))
        {
            return false;
        }
        for (k, &c) in all.iter().enumerate() {
            self.configs[g].push(Axes { c, ..a });
            self.nodes[g].push(Node {
                status,
                pose,
                counted: k == 0,
            });
        }
        true
    }

    /// Add the free configuration `a` to waypoint `g`'s column as it is
    /// (a rate-limited C value that is already one whole turn of C),
    /// unless the column holds it. Returns whether it was added.
    pub(super) fn push_free(&mut self, g: usize, a: Axes) -> bool {
        if self.configs[g].contains(&a) {
            return false;
        }
        let pose = self.next_pose(g);
        self.configs[g].push(a);
        self.nodes[g].push(Node {
            status: Status::Free,
            pose,
            counted: false,
        });
        true
    }

    /// Check IK pairs `(waypoint, [solution, mirror])` and add the free,
    /// feasible configurations to the columns (up to the cap). A
    /// half-turn-symmetric head needs one query per pair. Returns whether
    /// any feasible configuration was offered per item.
    pub(super) fn offer(
        &mut self,
        prover: &Prover,
        items: &[(usize, [(f64, f64); 2])],
        likely_free: bool,
    ) -> Result<Vec<bool>, PlanError> {
        let cand: Vec<Feasible> = items
            .par_iter()
            .map(|&(g, pair)| Feasible::of(pair.map(|tc| self.setup.feasible(g, tc))))
            .collect();
        let mut queries = Vec::new();
        let mut owner = Vec::new();
        for (k, (c, &(g, _))) in cand.iter().zip(items).enumerate() {
            let n = if self.setup.symmetric {
                c.len().min(1)
            } else {
                c.len()
            };
            for a in &c[..n] {
                queries.push((*a, cutoff(g)));
                owner.push(k);
            }
        }
        // Per query, the status its configurations enter with (`None`:
        // colliding, left out). Own orientations (`likely_free`) are asked
        // for what their beads need, clearance first.
        let entered: Vec<Option<Status>> = if likely_free {
            let needs = self.end_needs(prover, items, &cand, &queries, &owner);
            prover
                .poses_short_of_need(&queries, &needs)?
                .into_iter()
                .map(|short| Some(if short { Status::Tight } else { Status::Free }))
                .collect()
        } else {
            prover
                .poses(&queries)?
                .into_iter()
                .map(|hit| (!hit).then_some(Status::Free))
                .collect()
        };
        if self.setup.symmetric {
            // The mirror is the same head geometry: the same verdict.
            let mirrors: Vec<(Axes, u32, Axes)> = owner
                .iter()
                .zip(&queries)
                .flat_map(|(&k, q)| cand[k].mirrors(q.1))
                .collect();
            prover.same_as_each(&mirrors);
        }
        // Per item, its free configurations: a run of `entered` (a
        // symmetric head's pair is one query, entered whole).
        let cap = self.setup.opts.max_configs;
        let mut at = 0;
        for (k, &(g, _)) in items.iter().enumerate() {
            // A symmetric head's pair is one pose; otherwise each solution.
            let mut pose = self.next_pose(g);
            while at < owner.len() && owner[at] == k {
                let (q, status) = (queries[at], entered[at]);
                at += 1;
                let Some(status) = status else {
                    continue;
                };
                let free: &[Axes] = if self.setup.symmetric {
                    &cand[k]
                } else {
                    std::slice::from_ref(&q.0)
                };
                for &a in free {
                    let room = status == Status::Tight || self.live_count(g) < cap;
                    if room && self.push_config(g, a, status, pose) {
                        pose += (!self.setup.symmetric) as u32;
                    }
                }
            }
        }
        Ok(cand.iter().map(|c| !c.is_empty()).collect())
    }

    /// What each query `(a, g)` of `offer` (owned by `items[owner[i]]`)
    /// must keep so that the beads to the neighbouring waypoints' offered
    /// configurations (the nearest in rotation of each, as the graph
    /// usually takes them) start proven at this end ([`Prover::end_need`]).
    fn end_needs(
        &self,
        prover: &Prover,
        items: &[(usize, [(f64, f64); 2])],
        cand: &[Feasible],
        queries: &[(Axes, u32)],
        owner: &[usize],
    ) -> Vec<(f64, f64)> {
        // joined[g]: a bead is printed from g − 1 to g.
        let mut joined = vec![false; self.setup.toolpath.pos.len()];
        for r in &self.setup.toolpath.runs {
            joined[r.start + 1..r.end].fill(true);
        }
        queries
            .par_iter()
            .zip(owner)
            .map(|(&(a, _), &k)| {
                let g = items[k].0;
                let mut near = Vec::with_capacity(2);
                for (j, nb) in [(k.wrapping_sub(1), g.wrapping_sub(1)), (k + 1, g + 1)] {
                    let Some(&(h, _)) = items.get(j) else {
                        continue;
                    };
                    if h != nb || !joined[g.max(nb)] {
                        continue;
                    }
                    let nearest = cand[j]
                        .iter()
                        .map(|b| Axes {
                            c: self.setup.unwound(a.c, b.c),
                            ..*b
                        })
                        .min_by(|x, y| a.rotation_to(x).total_cmp(&a.rotation_to(y)));
                    near.extend(nearest);
                }
                prover.end_need(&a, &near)
            })
            .collect()
    }

    /// Empty columns over `setup`.
    fn new(setup: &'a Setup<'a>) -> Self {
        let n_wp = setup.waypoints();
        let (toolpath, rot) = (setup.toolpath, setup.machine.rotary);
        // The orientation each waypoint is planned around.
        let centre = (0..n_wp)
            .map(|g| {
                toolpath.singular_angles[g]
                    .map_or(toolpath.smoothed_dirs[g], |(t, c)| orientation(rot, t, c))
            })
            .collect();
        Columns {
            setup,
            configs: vec![Vec::new(); n_wp],
            nodes: vec![Vec::new(); n_wp],
            cursor: vec![EXHAUSTED; n_wp],
            misses: vec![0; n_wp],
            free_at: vec![u128::MAX; n_wp],
            probed: vec![false; n_wp],
            offered: vec![false; n_wp],
            centre,
            skip: vec![None; n_wp],
        }
    }

    /// Stage 3: the columns. Every waypoint's own IK solutions are asked
    /// (wide, for the beads to its neighbours); a waypoint whose own
    /// orientation collides gets a window of unchecked variants, or, with
    /// no feasible variant in the first round, the eager search; a
    /// waypoint that ends with an empty column is skipped.
    pub(super) fn build(setup: &'a Setup<'a>, prover: &Prover) -> Result<Self, PlanError> {
        Self::build_by(setup, prover, REFILL_BLOCK)
    }

    /// [`Columns::build`], the windows refilled `block` waypoints at a
    /// time ([`Columns::refill_by`]).
    fn build_by(setup: &'a Setup<'a>, prover: &Prover, block: usize) -> Result<Self, PlanError> {
        let mut columns = Self::new(setup);
        let toolpath = setup.toolpath;
        let n = setup.waypoints();
        let base: Vec<(usize, [(f64, f64); 2])> = (0..n).map(|g| (g, setup.own_pair(g))).collect();
        columns.offered = columns.offer(prover, &base, true)?;
        // (The batch's temporaries, freed among the new columns: see
        // `release_freed_memory`.)
        release_freed_memory();
        // A waypoint beyond the machine's reach is out of range in every
        // orientation: skipped at once rather than searched for one.
        let reach = setup.machine.reach();
        let within = |g: &usize| {
            let [x, y, z] = toolpath.pos[*g];
            x.hypot(y).hypot(z) <= reach
        };
        let (open, beyond): (Vec<usize>, Vec<usize>) = (0..n)
            .filter(|&g| columns.live_count(g) == 0)
            .partition(within);
        for g in beyond {
            columns.skip[g] = Some(Skip::Unreachable);
        }
        for &g in &open {
            columns.cursor[g] = 0;
        }
        columns.probe(prover, &open)?;
        release_freed_memory();
        let hard = columns.refill_by(&open, block);
        columns.search_harder(prover, &hard)?;
        for g in open {
            if columns.live_count(g) == 0 {
                columns.skip[g] = Some(columns.why_skipped(g));
            }
        }
        Ok(columns)
    }

    /// Pick the probes among the colliding waypoints `open` (each maximal
    /// run of consecutive ones in a continuous run of the toolpath: its
    /// ends and every [`PROBE_EVERY`]-th), ask their whole first rounds,
    /// and give every other waypoint of a run the variants free at the
    /// probes on either side of it as its plausible ones
    /// ([`Columns::plausible`]).
    fn probe(&mut self, prover: &Prover, open: &[usize]) -> Result<(), PlanError> {
        let groups = self.consecutive(open);
        let probes: Vec<usize> = groups
            .iter()
            .flat_map(|r| probe_positions(r.len()).into_iter().map(|i| r.start + i))
            .collect();
        // Every first-round variant of every probe, asked at once (a
        // half-turn-symmetric head's pair as one query): per item, its
        // waypoint, its variants' bits (`2 · item + solution`) and their
        // configurations.
        let symmetric = self.setup.symmetric;
        let items: Vec<(usize, u128, Feasible)> = probes
            .par_iter()
            .flat_map_iter(|&g| {
                let round = self.first_round(g);
                let mut items = Vec::new();
                for (i, pair) in round.iter().enumerate().take(PROBED_ITEMS) {
                    let each = pair.map(|tc| self.setup.feasible(g, tc));
                    let bit = |sol: usize| 1u128 << (2 * i + sol);
                    if symmetric && each.iter().any(Option::is_some) {
                        let bits = (0..2)
                            .filter(|&s| each[s].is_some())
                            .fold(0, |m, s| m | bit(s));
                        items.push((g, bits, Feasible::of(each)));
                    } else {
                        for (sol, a) in each.into_iter().enumerate() {
                            if let Some(a) = a {
                                items.push((g, bit(sol), Feasible::of([Some(a), None])));
                            }
                        }
                    }
                }
                items
            })
            .collect();
        let asked: Vec<(Axes, u32)> = items.iter().map(|(g, _, a)| (a[0], cutoff(*g))).collect();
        let hits = prover.poses(&asked)?;
        for &g in &probes {
            self.free_at[g] = 0;
        }
        let mirrors: Vec<(Axes, u32, Axes)> = items
            .iter()
            .flat_map(|(g, _, configs)| configs.mirrors(cutoff(*g)))
            .collect();
        prover.same_as_each(&mirrors);
        for ((g, bits, _), &hit) in items.iter().zip(&hits) {
            self.offered[*g] = true;
            if !hit {
                self.free_at[*g] |= bits;
            }
        }
        // The probes' columns: their free variants, in order, up to the cap.
        let cap = self.setup.opts.max_configs;
        for ((g, _, configs), &hit) in items.iter().zip(&hits) {
            let pose = self.next_pose(*g);
            for &a in configs.iter() {
                if !hit && self.live_count(*g) < cap {
                    self.push_config(*g, a, Status::Free, pose);
                }
            }
        }
        for &g in &probes {
            self.cursor[g] = EXHAUSTED;
            self.probed[g] = true;
        }
        // The others: bracketed by the probes on either side.
        for r in &groups {
            let mut last = r.start;
            for g in r.clone() {
                if self.probed[g] {
                    last = g;
                    continue;
                }
                let next = (g..r.end).find(|&h| self.probed[h]).unwrap_or(last);
                self.free_at[g] = self.free_at[last] & self.free_at[next];
            }
        }
        Ok(())
    }

    /// The maximal runs of consecutive waypoints of `which` (sorted)
    /// within one continuous run of the toolpath.
    fn consecutive(&self, which: &[usize]) -> Vec<Range<usize>> {
        let runs = &self.setup.toolpath.runs;
        let mut run = 0;
        let mut groups: Vec<Range<usize>> = Vec::new();
        for &g in which {
            let same_run = runs.get(run).is_some_and(|r| r.contains(&g));
            if !same_run {
                run = runs.partition_point(|r| r.end <= g);
            }
            match groups.last_mut() {
                Some(r) if same_run && r.end == g => r.end = g + 1,
                _ => groups.push(g..g + 1),
            }
        }
        groups
    }

    /// Is the variant `item` (`2 · item + solution`) of waypoint `g` worth
    /// a path's trying: free at the probes on either side of it (or past
    /// what the probes asked)?
    fn plausible(&self, g: usize, item: usize) -> bool {
        item >= 2 * PROBED_ITEMS || self.free_at[g] & (1u128 << item) != 0
    }

    /// Why waypoint `g`, with nothing left in its column, is skipped.
    pub(super) fn why_skipped(&self, g: usize) -> Skip {
        if self.offered[g] {
            Skip::Residual
        } else {
            Skip::Unreachable
        }
    }

    /// Waypoint `g`'s first round of variants, as IK pairs in the order
    /// they are offered: its own, unsmoothed orientation first
    /// (smoothing must not make a free waypoint collide), then one
    /// pattern of samples for every waypoint (neighbours get matching
    /// candidates, so the graph can keep the motion smooth).
    fn first_round(&self, g: usize) -> Vec<[(f64, f64); 2]> {
        let rot = self.setup.machine.rotary;
        let sampled = candidates::round(
            self.centre[g],
            0,
            0,
            self.setup.opts.sampling,
            self.setup.opts.beta,
            self.setup.opts.alpha,
        );
        std::iter::once(self.setup.toolpath.input_dirs[g])
            .chain(sampled)
            .map(|d| ik_angles(rot, d))
            .collect()
    }

    /// [`Columns::refill`] for the waypoints `block`: their next
    /// configurations found in parallel ([`Columns::next_configs`]), then
    /// entered in order ([`Columns::enter`]). A column with no variant
    /// free at the probes around it enters none: it goes to the eager
    /// search first, and enters them only if that finds nothing
    /// ([`Columns::enter_doubtful`]) — on a steep part most columns are
    /// such, and their implausible variants were most of the planner's
    /// memory.
    fn refill_block(&mut self, block: &[usize]) {
        let next: Vec<(usize, Vec<Next>, u32)> = block
            .par_iter()
            .filter(|&&g| self.cursor[g] != EXHAUSTED && self.free_at[g] != 0)
            .map(|&g| {
                let (configs, cursor) = self.next_configs(g, false);
                (g, configs, cursor)
            })
            .collect();
        for (g, configs, cursor) in next {
            self.enter(g, configs, cursor);
        }
    }

    /// Waypoint `g`'s column, left with nothing live by the eager search:
    /// the rest of its first round enters, every variant unchecked,
    /// implausible or not. Returns whether any did.
    fn enter_doubtful(&mut self, g: usize) -> bool {
        if self.cursor[g] == EXHAUSTED {
            return false;
        }
        let (configs, cursor) = self.next_configs(g, true);
        let any = !configs.is_empty();
        self.enter(g, configs, cursor);
        any
    }

    /// Waypoint `g`'s next variants from its cursor, each with the number
    /// of its item among them (its IK solutions share a pose) and the
    /// status it enters with: until the window holds `max_configs`
    /// plausible ones (the implausible ones enter too, and do not count),
    /// or, with `all`, every one left, unchecked. Returns them and the
    /// cursor after them: one flat list per waypoint (a list per item
    /// would make this the planner's peak of memory where most waypoints
    /// collide).
    fn next_configs(&self, g: usize, all: bool) -> (Vec<Next>, u32) {
        let want = if all {
            usize::MAX
        } else {
            self.setup
                .opts
                .max_configs
                .saturating_sub(self.live_count(g))
        };
        let items = self.first_round(g);
        let mut at = self.cursor[g] as usize;
        let (mut got, mut count) = (Vec::new(), 0);
        while at < items.len() && count < want {
            for (sol, &tc) in items[at].iter().enumerate() {
                if let Some(a) = self.setup.feasible(g, tc) {
                    let status = if all || self.plausible(g, 2 * at + sol) {
                        count += 1;
                        Status::Unknown
                    } else {
                        Status::Unlikely
                    };
                    got.push((at as u32, a, status));
                }
            }
            at += 1;
        }
        let cursor = if at < items.len() {
            at as u32
        } else {
            EXHAUSTED
        };
        (got, cursor)
    }

    /// Enter `configs` ([`Columns::next_configs`]) into waypoint `g`'s
    /// column, the unchecked ones up to the cap, and move its cursor.
    fn enter(&mut self, g: usize, configs: Vec<Next>, cursor: u32) {
        let cap = self.setup.opts.max_configs;
        self.cursor[g] = cursor;
        self.offered[g] |= !configs.is_empty();
        let mut item = None;
        let mut pose = 0;
        // (Counted as they enter: a count per configuration would make
        // this loop quadratic in the column's length.)
        let mut live = self.live_count(g);
        self.configs[g].reserve(configs.len());
        self.nodes[g].reserve(configs.len());
        for (at, a, status) in configs {
            if item != Some(at) {
                item = Some(at);
                pose = self.next_pose(g);
            }
            let room = status == Status::Unlikely || live < cap;
            if room && self.push_config(g, a, status, pose) {
                pose += (!self.setup.symmetric) as u32;
                live += (status == Status::Unknown) as usize;
            }
        }
        // Columns are long-lived (until the program): no spare room.
        self.configs[g].shrink_to_fit();
        self.nodes[g].shrink_to_fit();
    }

    /// Fill the windows of the lazily filled columns `which` up to the cap
    /// with unchecked variants from their cursors (the implausible ones
    /// enter too, [`Status::Unlikely`], but do not count). A column left
    /// with nothing live and no variant to come has its nodes held aside
    /// promoted ([`Columns::promote`]); one with no variant free at the
    /// probes around it enters no variants. Returns the columns with
    /// nothing live and nothing promoted, and those with no variant free
    /// at their probes: they need the eager search
    /// ([`Columns::search_harder`]), which enters or promotes what it
    /// cannot replace.
    pub(super) fn refill(&mut self, which: &[usize]) -> Vec<usize> {
        self.refill_by(which, REFILL_BLOCK)
    }

    /// [`Columns::refill`], `block` waypoints at a time: otherwise the
    /// configurations waiting to enter would all be held beside the
    /// columns they enter, at the planner's peak of memory. A waypoint's
    /// configurations depend on its own column only, so the blocks enter
    /// what one pass would.
    fn refill_by(&mut self, which: &[usize], block: usize) -> Vec<usize> {
        for part in which.chunks(block.max(1)) {
            self.refill_block(part);
        }
        let mut empty = Vec::new();
        for &g in which {
            // With no variant free at the probes around it, the eager
            // search (its grazing own configuration first) comes before
            // its variants.
            let doubtful = self.free_at[g] == 0;
            if self.live_count(g) > 0 || (self.cursor[g] != EXHAUSTED && !doubtful) {
                continue;
            }
            if doubtful || !self.promote(g) {
                empty.push(g);
            }
        }
        empty
    }

    /// Waypoint `g`'s column holds nothing live: the nodes it holds aside
    /// become unchecked, its implausible variants ([`Status::Unlikely`])
    /// if it has any, else its own configuration that fell short of its
    /// beads' need ([`Status::Tight`]). Returns whether any did.
    fn promote(&mut self, g: usize) -> bool {
        for from in [Status::Unlikely, Status::Tight] {
            let mut promoted = false;
            for n in &mut self.nodes[g] {
                if n.status == from {
                    n.status = Status::Unknown;
                    promoted = true;
                }
            }
            if promoted {
                return true;
            }
        }
        false
    }

    /// Ask the unchecked nodes `asks`, `(waypoint, node, need)`: one query
    /// per pose, at the largest `(margin, slope)` its asks need (the level
    /// the beads to its path's neighbours ask of this end,
    /// [`Prover::end_need`]); one that fails that is asked again at the
    /// pose margin. Colliding nodes die and their windows refill. Returns
    /// the waypoints whose nodes died.
    pub(super) fn check_nodes(
        &mut self,
        prover: &Prover,
        asks: &[(usize, usize, (f64, f64))],
    ) -> Result<Vec<usize>, PlanError> {
        // One query per (waypoint, pose), first node of the pose asks.
        let mut group: HashMap<(usize, u32), usize> = HashMap::default();
        let mut items: Vec<(Axes, u32)> = Vec::new();
        let mut needs: Vec<(f64, f64)> = Vec::new();
        let mut which: Vec<(usize, u32)> = Vec::new();
        for &(g, j, need) in asks {
            let pose = self.nodes[g][j].pose;
            match group.get(&(g, pose)) {
                Some(&q) => {
                    needs[q] = (needs[q].0.max(need.0), needs[q].1.max(need.1));
                }
                None => {
                    group.insert((g, pose), items.len());
                    items.push((self.configs[g][j], cutoff(g)));
                    needs.push(need);
                    which.push((g, pose));
                }
            }
        }
        // A variant is taken as it comes, grazing or not (only a
        // waypoint's own orientation is held to clearance first).
        let hits = prover.poses_wide(&items, &needs)?;
        let mut died = Vec::new();
        let mut same = Vec::new();
        for ((&(g, pose), &(a, c)), hit) in which.iter().zip(&items).zip(hits) {
            let status = if hit { Status::Hit } else { Status::Free };
            for (k, node) in self.nodes[g].iter_mut().enumerate() {
                if node.pose == pose {
                    node.status = status;
                    if !hit && self.configs[g][k] != a {
                        // A mirror or a winding: the same head geometry.
                        same.push((self.configs[g][k], c, a));
                    }
                }
            }
            if hit {
                self.misses[g] = self.misses[g].saturating_add(1);
                if died.last() != Some(&g) {
                    died.push(g);
                }
            }
        }
        prover.same_as_each(&same);
        died.sort_unstable();
        died.dedup();
        Ok(died)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{graph, head_reach, PlanOptions, Prepared};
    use super::*;
    use crate::collide::cpu::CpuBackend;
    use crate::collide::{Backend, CollideError};
    use crate::kinematics::Machine;
    use crate::scene::{Query, Scene};
    use glam::Vec3;

    /// The default job, prepared with the default settings, to plan over
    /// one backend or another.
    struct Fixture {
        scene: Scene,
        machine: Machine,
        opts: PlanOptions,
        prepared: Prepared,
    }

    impl Fixture {
        fn new() -> Self {
            let job = crate::default_job::job();
            let machine = Machine::default();
            let opts = PlanOptions::default();
            let prepared = Prepared::new(&job.toolpath, &machine, &opts);
            Fixture {
                scene: crate::default_job::scene(),
                machine,
                opts,
                prepared,
            }
        }

        fn setup(&self) -> Setup<'_> {
            Setup::new(&self.scene, &self.prepared, &self.machine, &self.opts)
        }

        /// A prover over `backend` at a 0.05 mm margin.
        fn prover<'b>(&'b self, backend: &'b dyn Backend) -> Prover<'b> {
            let reach = head_reach(&self.scene);
            Prover::new(&self.machine, backend, reach, 0.05, self.opts.edge_step)
        }
    }

    /// The angle (radians) between a head axis and the default job's
    /// shell normal at its tip (the shells are spheres about the origin).
    fn off_normal(tip: [f32; 3], axis: [f32; 3]) -> f32 {
        let (tip, axis) = (Vec3::from(tip), Vec3::from(axis));
        (axis.dot(tip) / tip.length()).clamp(-1.0, 1.0).acos()
    }

    /// A backend for the default job where a pose whose head axis lies
    /// `lo..hi` radians off the shell's normal at its tip *grazes* (free at
    /// the pose margin, colliding at any margin above 0.1 mm); any other
    /// pose is clear, or, with `others_collide`, collides.
    struct Grazing {
        lo: f32,
        hi: f32,
        others_collide: bool,
    }

    impl Backend for Grazing {
        fn name(&self) -> &'static str {
            "grazing"
        }
        fn evaluate(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
            Ok(q.iter()
                .map(|q| {
                    let a = off_normal(q.pose.tip, q.pose.cols[2]);
                    if a >= self.lo && a < self.hi {
                        q.margin > 0.1
                    } else {
                        self.others_collide
                    }
                })
                .collect())
        }
    }

    /// One waypoint of [`planned`]: how far its own configuration (as the
    /// columns first offer it) lies off the normal, and, unless it was
    /// skipped, whether the path takes that configuration and how far the
    /// planned one lies off the normal.
    type Planned = (f32, Option<(bool, f32)>);

    /// The default job's columns and paths over `backend`.
    fn planned(backend: &dyn Backend) -> Vec<Planned> {
        let fixture = Fixture::new();
        let setup = fixture.setup();
        let prover = fixture.prover(backend);
        let columns = Columns::build(&setup, &prover).unwrap();
        let route = graph::route(columns, &prover).unwrap();
        let angle = |a: &Axes| {
            let pose = fixture.machine.pose(a);
            off_normal(pose.tip, pose.cols[2])
        };
        let own = |g: usize| {
            let pair = setup.own_pair(g);
            pair.iter().find_map(|&tc| setup.feasible(g, tc))
        };
        let mut out: Vec<Planned> = (0..setup.waypoints())
            .map(|g| (own(g).as_ref().map_or(f32::INFINITY, angle), None))
            .collect();
        for section in &route.sections {
            for (k, g) in section.waypoints.clone().enumerate() {
                let a = section.axes[k];
                let pair = setup.own_pair(g);
                let taken = pair.iter().any(|&tc| setup.feasible(g, tc) == Some(a));
                out[g].1 = Some((taken, angle(&a)));
            }
        }
        out
    }

    /// A waypoint whose own orientation only grazes gets variants with
    /// room, and the path takes one: with every pose within 2° of the
    /// shell's normal grazing, no waypoint is planned in its own
    /// configuration there (many are when those poses are clear).
    #[test]
    fn a_grazing_orientation_gives_way_to_a_variant_with_room() {
        let hi = 2f32.to_radians();
        let kept = |plan: &[Planned]| {
            plan.iter()
                .filter(|w| matches!(w.1, Some((true, a)) if a < hi))
                .count()
        };
        let grazes = planned(&Grazing {
            lo: 0.0,
            hi,
            others_collide: false,
        });
        assert!(grazes.iter().all(|w| w.1.is_some()), "a waypoint skipped");
        assert_eq!(kept(&grazes), 0, "planned as they graze");
        let clear = planned(&Grazing {
            lo: 0.0,
            hi: 0.0,
            others_collide: false,
        });
        assert!(
            kept(&clear) * 4 > clear.len(),
            "{} of {}",
            kept(&clear),
            clear.len()
        );
    }

    /// Where a grazing own orientation is all a waypoint has (every other
    /// pose collides), its column falls back on it before the eager
    /// search: each such waypoint is planned, in that configuration.
    #[test]
    fn a_grazing_orientation_is_taken_when_nothing_else_is_free() {
        // The first variant, the unsmoothed normal, collides (below lo).
        let (lo, hi) = (0.5f32.to_radians(), 3f32.to_radians());
        let plan = planned(&Grazing {
            lo,
            hi,
            others_collide: true,
        });
        let grazing: Vec<&Planned> = plan.iter().filter(|w| w.0 >= lo && w.0 < hi).collect();
        assert!(
            grazing.len() > 100,
            "{} grazing own orientations",
            grazing.len()
        );
        for w in grazing {
            assert!(matches!(w.1, Some((true, _))), "{w:?}");
        }
    }

    /// Offering a waypoint's candidates in waves, stopping once its column
    /// is full, keeps the very configurations that offering them all at
    /// once keeps (the first free ones, in order, up to the cap), and
    /// asks fewer queries.
    #[test]
    fn offering_until_full_keeps_the_same_columns_with_fewer_queries() {
        let fixture = Fixture::new();
        let (machine, opts) = (&fixture.machine, &fixture.opts);
        let backend = CpuBackend::new(&fixture.scene);
        let top = machine
            .tilt
            .min
            .abs()
            .max(machine.tilt.max.abs())
            .to_radians();
        let grid = candidates::reachable_directions(top, opts.exhaustive_step);
        // Every reachable direction for every 40th waypoint: most are free
        // on this part, far more than the cap keeps.
        let n = fixture.scene.waypoint_queries.len();
        let items: Vec<(usize, [(f64, f64); 2])> = (0..n)
            .step_by(40)
            .flat_map(|g| grid.iter().map(move |d| (g, *d)))
            .collect();
        let setup = fixture.setup();
        let columns = |waves: bool| {
            let mut columns = Columns::new(&setup);
            let prover = fixture.prover(&backend);
            let offered = if waves {
                columns.offer_until_full(&prover, &items).unwrap()
            } else {
                columns.offer(&prover, &items, false).unwrap()
            };
            let mut any = vec![false; n];
            for (it, o) in items.iter().zip(offered) {
                any[it.0] |= o;
            }
            (columns.configs, any, prover.queries())
        };
        let (all, all_offered, all_queries) = columns(false);
        let (waved, waved_offered, waved_queries) = columns(true);
        assert!(
            all.iter().filter(|c| c.len() == opts.max_configs).count() > 10,
            "full columns to compare"
        );
        assert_eq!(waved, all);
        assert_eq!(waved_offered, all_offered);
        assert!(
            waved_queries * 4 < all_queries,
            "{waved_queries} queries in waves, {all_queries} at once"
        );
    }

    /// A steep part: only orientations 50–80° off the shell's normal are
    /// free, so every variant of a first round, and of the wider rounds
    /// near it, collides.
    fn steep() -> Grazing {
        Grazing {
            lo: 50f32.to_radians(),
            hi: 80f32.to_radians(),
            others_collide: true,
        }
    }

    /// On a [`steep`] part the eager search seeded by its probes
    /// fills every column that searching each waypoint on its own fills,
    /// with configurations the backend finds free, for a fraction of the
    /// queries.
    #[test]
    fn the_eager_search_seeded_by_probes_fills_each_column_for_a_fraction_of_the_queries() {
        let fixture = Fixture::new();
        let backend = steep();
        let setup = fixture.setup();
        let open: Vec<usize> = (0..setup.waypoints()).collect();
        let search = |seeded: bool| {
            let prover = fixture.prover(&backend);
            let mut columns = Columns::new(&setup);
            if seeded {
                columns.search_harder(&prover, &open).unwrap();
            } else {
                columns.search_wide(&prover, open.clone()).unwrap();
            }
            (columns, prover.queries())
        };
        let (seeded, seeded_queries) = search(true);
        let (alone, alone_queries) = search(false);
        let filled =
            |c: &Columns| -> Vec<bool> { open.iter().map(|&g| c.live_count(g) > 0).collect() };
        assert!(filled(&alone).iter().all(|&f| f), "a column left empty");
        assert_eq!(filled(&seeded), filled(&alone));
        // Every configuration the seeded columns hold free, asked again
        // one by one.
        let prover = fixture.prover(&backend);
        for &g in &open {
            for (a, n) in seeded.configs[g].iter().zip(&seeded.nodes[g]) {
                assert_eq!(n.status, Status::Free);
                let query = Query {
                    pose: fixture.machine.pose(a),
                    cutoff: cutoff(g),
                    margin: prover.pose_margin() as f32,
                    slope: 0.0,
                };
                assert_eq!(backend.evaluate(&[query]).unwrap(), [false], "waypoint {g}");
            }
        }
        assert!(
            seeded_queries * 2 < alone_queries,
            "{seeded_queries} queries seeded, {alone_queries} alone"
        );
    }

    /// A column with no variant free at the probes around it does not
    /// hold its first round's variants once the eager search fills it
    /// (on a steep part they were most of the planner's memory): on a
    /// [`steep`] part every column is filled, and those with nothing
    /// plausible (most) hold no implausible variant.
    #[test]
    fn a_column_filled_by_the_eager_search_holds_no_implausible_variants() {
        let fixture = Fixture::new();
        let backend = steep();
        let setup = fixture.setup();
        let prover = fixture.prover(&backend);
        let columns = Columns::build(&setup, &prover).unwrap();
        let n = setup.waypoints();
        assert!(
            (0..n).all(|g| columns.live_count(g) > 0),
            "a column left empty"
        );
        let doubtful: Vec<usize> = (0..n).filter(|&g| columns.free_at[g] == 0).collect();
        assert!(doubtful.len() * 2 > n, "{} of {n}", doubtful.len());
        for g in doubtful {
            let held = |s: Status| columns.nodes[g].iter().filter(|n| n.status == s).count();
            assert!(held(Status::Free) > 0, "waypoint {g}");
            assert_eq!(held(Status::Unlikely), 0, "waypoint {g}");
        }
    }

    /// The columns' windows refilled a waypoint at a time are those one
    /// pass over every colliding waypoint fills (the blocks that bound
    /// the refill's memory change nothing), on a toolpath where every
    /// waypoint's own orientation collides.
    #[test]
    fn refilling_in_blocks_fills_the_columns_one_pass_fills() {
        let fixture = Fixture::new();
        // Free only 4–12° off the shell's normal: the waypoints' own
        // orientations (smoothed normals) collide, some variants do not.
        let backend = Grazing {
            lo: 4f32.to_radians(),
            hi: 12f32.to_radians(),
            others_collide: true,
        };
        let setup = fixture.setup();
        let columns = |block: usize| {
            let prover = fixture.prover(&backend);
            let c = Columns::build_by(&setup, &prover, block).unwrap();
            (c.configs, c.nodes, c.cursor, c.skip)
        };
        let whole = columns(usize::MAX);
        let one_by_one = columns(1);
        let unknown = whole
            .1
            .iter()
            .flatten()
            .filter(|n| n.status == Status::Unknown)
            .count();
        assert!(unknown > 100, "{unknown} unchecked variants to compare");
        assert!(whole == one_by_one, "the columns differ");
    }
}
