//! The eager search of the columns ([`super::Columns::search_harder`]):
//! for a waypoint whose first round of variants all collide, the free
//! orientations of its neighbours first — runs of such waypoints are
//! probed, and the probes searched before the waypoints between them —
//! then wider rounds, then every orientation the machine can reach, each
//! offered a wave at a time until the column holds a free configuration.
//! Its last resort lists many more directions than a column keeps, so it
//! stops asking a waypoint once its column is full
//! ([`super::Columns::offer_until_full`]).

use super::{probe_positions, Columns, Status};
use crate::kinematics::{ik_angles, orientation};
use crate::plan::{candidates, PlanError};
use crate::prove::Prover;
use crate::scene::cutoff;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;

/// An IK pair `[solution, mirror]` of `(tilt, C)` offered to a waypoint.
type Offer = (usize, [(f64, f64); 2]);

impl Columns<'_> {
    /// [`Columns::offer`] for items that list each waypoint's candidates
    /// together, in the order they should be preferred: a waypoint's items
    /// are offered a wave of `max_configs` at a time, and a waypoint whose
    /// column is full asks no more. A column keeps the first free
    /// configurations in item order up to the cap either way, so the
    /// columns are the same as offering every item at once; what changes
    /// is that the items the cap would drop are never asked (the last
    /// resort's shells list hundreds of directions per waypoint, many of
    /// them free, to keep `max_configs`).
    /// Waves hold at most 2²⁰ items, which bounds the batch's memory.
    pub(super) fn offer_until_full(
        &mut self,
        prover: &Prover,
        items: &[(usize, [(f64, f64); 2])],
    ) -> Result<Vec<bool>, PlanError> {
        const MOST: usize = 1 << 20;
        let (wave, cap) = (
            self.setup.opts.max_configs.max(1),
            self.setup.opts.max_configs,
        );
        // Each waypoint's items: a contiguous range.
        let mut groups: Vec<Range<usize>> = Vec::new();
        for (i, it) in items.iter().enumerate() {
            match groups.last_mut() {
                Some(r) if items[r.start].0 == it.0 => r.end = i + 1,
                _ => groups.push(i..i + 1),
            }
        }
        let mut offered = vec![false; items.len()];
        let mut next: Vec<usize> = groups.iter().map(|r| r.start).collect();
        loop {
            let mut asked: Vec<usize> = Vec::new();
            for (r, at) in groups.iter().zip(next.iter_mut()) {
                if *at == r.end || self.live_count(items[r.start].0) >= cap {
                    continue;
                }
                if asked.len() + wave > MOST && !asked.is_empty() {
                    break;
                }
                let end = (*at + wave).min(r.end);
                asked.extend(*at..end);
                *at = end;
            }
            if asked.is_empty() {
                return Ok(offered);
            }
            let wave_items: Vec<_> = asked.iter().map(|&i| items[i]).collect();
            for (&i, o) in asked.iter().zip(self.offer(prover, &wave_items, false)?) {
                offered[i] = o;
            }
        }
    }

    /// The eager search for waypoints whose columns hold nothing live,
    /// run by run of consecutive ones ([`Columns::search_seeded`]); those
    /// it leaves empty get the configurations their columns hold aside
    /// ([`Columns::promote`]), or stay empty (the caller skips them).
    pub(in crate::plan) fn search_harder(
        &mut self,
        prover: &Prover,
        open: &[usize],
    ) -> Result<(), PlanError> {
        let mut sorted = open.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        self.ask_tight(prover, &sorted)?;
        let lists: Vec<Vec<usize>> = self
            .consecutive(&sorted)
            .into_iter()
            .map(|r| r.collect())
            .collect();
        self.search_seeded(prover, &lists)?;
        for g in sorted {
            if self.live_count(g) == 0 && !self.enter_doubtful(g) {
                self.promote(g);
            }
            // Columns are long-lived (until the program): no spare room.
            self.configs[g].shrink_to_fit();
            self.nodes[g].shrink_to_fit();
        }
        Ok(())
    }

    /// The own configurations that `open`'s columns hold aside as
    /// [`Status::Tight`], asked at the pose margin: one that only grazes
    /// is free, and taken before the eager search looks farther from the
    /// waypoint's own orientation; one that collides dies.
    fn ask_tight(&mut self, prover: &Prover, open: &[usize]) -> Result<(), PlanError> {
        let mut which: Vec<(usize, u32)> = Vec::new();
        let mut items = Vec::new();
        for &g in open {
            for (a, n) in self.configs[g].iter().zip(&self.nodes[g]) {
                if n.status == Status::Tight && which.last() != Some(&(g, n.pose)) {
                    which.push((g, n.pose));
                    items.push((*a, cutoff(g)));
                }
            }
        }
        let hits = prover.poses(&items)?;
        for (&(g, pose), hit) in which.iter().zip(hits) {
            for n in self.nodes[g].iter_mut().filter(|n| n.pose == pose) {
                n.status = if hit { Status::Hit } else { Status::Free };
            }
        }
        Ok(())
    }

    /// The eager search for `lists` of neighbouring waypoints, probed as
    /// the first round is ([`super::PROBE_EVERY`]): the probes are
    /// searched first (the same way, among themselves, so only every
    /// [`super::PROBE_EVERY`]-th of them is searched on its own), and
    /// every other waypoint is offered the free orientations of the
    /// probes on either side of it, nearest its own first — where a
    /// waypoint's first round all collides (a steep part), its
    /// neighbours' free orientations lie far out, and finding them anew
    /// costs a hundred queries a waypoint. One whose offers all collide
    /// is offered its list neighbours' free orientations, and then
    /// searched on its own ([`Columns::search_wide`]).
    fn search_seeded(&mut self, prover: &Prover, lists: &[Vec<usize>]) -> Result<(), PlanError> {
        let probes: Vec<Vec<usize>> = lists.iter().map(|l| probe_positions(l.len())).collect();
        let (n, probed) = (
            lists.iter().map(Vec::len).sum::<usize>(),
            probes.iter().map(Vec::len).sum::<usize>(),
        );
        if probed == n {
            return self.search_wide(prover, lists.concat());
        }
        let coarse: Vec<Vec<usize>> = lists
            .iter()
            .zip(&probes)
            .map(|(l, p)| p.iter().map(|&i| l[i]).collect())
            .collect();
        self.search_seeded(prover, &coarse)?;
        // Between probes: seeded by the probes on either side.
        let mut spans = Vec::new();
        for (l, p) in lists.iter().zip(&probes) {
            for w in p.windows(2) {
                spans.push((l[w[0]], l[w[1]], l[w[0] + 1..w[1]].to_vec()));
            }
        }
        let mut open: Vec<usize> = spans.iter().flat_map(|s| s.2.iter().copied()).collect();
        self.offer_to_open(prover, &self.seeded(&spans), &mut open)?;
        // Still empty: seeded by their own neighbours, most of which
        // found room.
        let mut spans = Vec::new();
        for l in lists {
            for (i, &g) in l.iter().enumerate() {
                if open.binary_search(&g).is_ok() {
                    let (a, b) = (l[i.saturating_sub(1)], l[(i + 1).min(l.len() - 1)]);
                    spans.push((a, b, vec![g]));
                }
            }
        }
        self.offer_to_open(prover, &self.seeded(&spans), &mut open)?;
        self.search_wide(prover, open)
    }

    /// Wider rounds of variants for the waypoints of `open`, then, for
    /// those still without a live configuration, every orientation the
    /// machine can reach (5° apart), nearest first in shells of 30°, each
    /// asked until the column holds a free configuration.
    pub(super) fn search_wide(
        &mut self,
        prover: &Prover,
        mut open: Vec<usize>,
    ) -> Result<(), PlanError> {
        open.retain(|&g| self.live_count(g) == 0);
        self.wider_rounds(prover, &mut open)?;
        // Last resort before giving a waypoint up.
        if !open.is_empty() {
            self.every_reachable(prover, &mut open)?;
        }
        Ok(())
    }

    /// Per `(a, b, targets)`: each target offered the orientations free at
    /// waypoints `a` and `b`, nearest its own first, as IK pairs.
    fn seeded(&self, spans: &[(usize, usize, Vec<usize>)]) -> Vec<Offer> {
        let rot = self.setup.machine.rotary;
        let free_dirs = |h: usize, dirs: &mut Vec<DVec3>| {
            for (a, n) in self.configs[h].iter().zip(&self.nodes[h]) {
                let d = DVec3::from(orientation(rot, a.tilt, a.c));
                // (Windings and mirror solutions point the same way.)
                if n.status == Status::Free && dirs.iter().all(|e| e.dot(d) < 1.0 - 1e-12) {
                    dirs.push(d);
                }
            }
        };
        let per_span: Vec<Vec<Offer>> = spans
            .par_iter()
            .map(|(a, b, targets)| {
                let mut seeds = Vec::new();
                free_dirs(*a, &mut seeds);
                free_dirs(*b, &mut seeds);
                let mut items = Vec::new();
                for &g in targets {
                    let c = DVec3::from(self.centre[g]);
                    let mut near = seeds.clone();
                    near.sort_by(|x, y| c.dot(*y).total_cmp(&c.dot(*x)));
                    items.extend(near.into_iter().map(|d| (g, ik_angles(rot, d.to_array()))));
                }
                items
            })
            .collect();
        per_span.concat()
    }

    /// The rounds of variants after the first, widened 10 % each, until
    /// every waypoint of `open` has a live configuration or the sampling
    /// is exhausted.
    fn wider_rounds(&mut self, prover: &Prover, open: &mut Vec<usize>) -> Result<(), PlanError> {
        let (rot, opts) = (self.setup.machine.rotary, self.setup.opts);
        let mut round = 1u32;
        while !open.is_empty() {
            let centre = &self.centre;
            let items: Vec<Offer> = open
                .par_iter()
                .flat_map_iter(|&g| {
                    let sampled = candidates::round(
                        centre[g],
                        0,
                        round,
                        opts.sampling,
                        opts.beta,
                        opts.alpha,
                    );
                    sampled.into_iter().map(move |d| (g, ik_angles(rot, d)))
                })
                .collect();
            if items.is_empty() {
                break; // Sampling exhausted.
            }
            self.offer_to_open(prover, &items, open)?;
            round += 1;
        }
        Ok(())
    }

    /// Every orientation the machine can reach, for the waypoints of
    /// `open`: nearest first, in shells of widening angle.
    fn every_reachable(&mut self, prover: &Prover, open: &mut Vec<usize>) -> Result<(), PlanError> {
        let m = self.setup.machine;
        let top = m.tilt.min.abs().max(m.tilt.max.abs()).to_radians();
        let grid = candidates::reachable_directions(top, self.setup.opts.exhaustive_step);
        let dirs: Vec<DVec3> = grid
            .iter()
            .map(|p| DVec3::from(orientation(m.rotary, p[0].0, p[0].1)))
            .collect();
        let shell = 30f64.to_radians();
        let mut lo = 0.0;
        while !open.is_empty() && lo <= std::f64::consts::PI {
            let hi = lo + shell;
            let (centre, dirs, grid) = (&self.centre, &dirs, &grid);
            let items: Vec<Offer> = open
                .par_iter()
                .flat_map_iter(|&g| {
                    let c = DVec3::from(centre[g]);
                    let mut near: Vec<(f64, usize)> = dirs
                        .iter()
                        .enumerate()
                        .map(|(k, d)| (d.dot(c).clamp(-1.0, 1.0).acos(), k))
                        .filter(|&(a, _)| a >= lo && a < hi)
                        .collect();
                    near.sort_by(|a, b| a.0.total_cmp(&b.0));
                    near.into_iter().map(move |(_, k)| (g, grid[k]))
                })
                .collect();
            self.offer_to_open(prover, &items, open)?;
            lo = hi;
        }
        Ok(())
    }

    /// One step of [`Columns::search_harder`]: offer `items` until full,
    /// note which waypoints had a feasible configuration, and keep in
    /// `open` the waypoints still without a live one.
    fn offer_to_open(
        &mut self,
        prover: &Prover,
        items: &[(usize, [(f64, f64); 2])],
        open: &mut Vec<usize>,
    ) -> Result<(), PlanError> {
        for (&(g, _), o) in items.iter().zip(self.offer_until_full(prover, items)?) {
            self.offered[g] |= o;
        }
        open.retain(|&g| self.live_count(g) == 0);
        Ok(())
    }
}
