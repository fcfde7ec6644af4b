//! The eager search of the columns ([`super::Columns::search_harder`]):
//! for a waypoint whose first round of variants all collide, wider rounds,
//! then every orientation the machine can reach, each offered a wave at a
//! time until the column holds a free configuration. Its last resort
//! lists many more directions than a column keeps, so it stops asking a
//! waypoint once its column is full ([`super::Columns::offer_until_full`]).

use super::Columns;
use crate::kinematics::{ik_angles, orientation};
use crate::plan::{candidates, PlanError};
use crate::prove::Prover;
use glam::DVec3;
use std::ops::Range;

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

    /// The eager search for waypoints whose columns hold nothing live:
    /// wider rounds of variants, then every orientation the machine can
    /// reach (5° apart), nearest first in shells of 30°, each asked until
    /// the column holds a free configuration. Waypoints still without one
    /// are left with empty columns (the caller skips them).
    pub(in crate::plan) fn search_harder(
        &mut self,
        prover: &Prover,
        open: &[usize],
    ) -> Result<(), PlanError> {
        let mut open = open.to_vec();
        self.wider_rounds(prover, &mut open)?;
        // Last resort before giving a waypoint up.
        if !open.is_empty() {
            self.every_reachable(prover, &mut open)?;
        }
        Ok(())
    }

    /// The rounds of variants after the first, widened 10 % each, until
    /// every waypoint of `open` has a live configuration or the sampling
    /// is exhausted.
    fn wider_rounds(&mut self, prover: &Prover, open: &mut Vec<usize>) -> Result<(), PlanError> {
        let (rot, opts) = (self.setup.machine.rotary, self.setup.opts);
        let mut round = 1u32;
        while !open.is_empty() {
            let mut items = Vec::new();
            for &g in open.iter() {
                let sampled = candidates::round(
                    self.centre[g],
                    0,
                    round,
                    opts.sampling,
                    opts.beta,
                    opts.alpha,
                );
                for d in sampled {
                    items.push((g, ik_angles(rot, d)));
                }
            }
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
            let mut items = Vec::new();
            for &g in open.iter() {
                let c = DVec3::from(self.centre[g]);
                let mut near: Vec<(f64, usize)> = dirs
                    .iter()
                    .enumerate()
                    .map(|(k, d)| (d.dot(c).clamp(-1.0, 1.0).acos(), k))
                    .filter(|&(a, _)| a >= lo && a < hi)
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0));
                items.extend(near.into_iter().map(|(_, k)| (g, grid[k])));
            }
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
