//! Raster fills of one planar slice (paper 003, Fig. 3 and Sec. 2.2): the
//! slice's grid points come as *runs* — maximal rows of consecutive grid
//! points inside the region, so cavities split rows and islands add runs —
//! and a fill decides the order and direction in which runs are printed.
//!
//! - **zig-zag**: row by row, alternating direction; a row split by a cavity
//!   is crossed (travel over the cavity) and continued;
//! - **one-way** (zig): row by row, always in the same direction, so every
//!   row ends with a travel back;
//! - **MZZ** (modified zig-zag, Wojcik et al., as paper 003 uses it): from
//!   the end of each run, continue with the nearest end of any unprinted
//!   run (either direction, any row), so the path keeps zig-zagging inside
//!   one section of the slice and only jumps when the section is done; then
//!   the path optimisation of Sec. 2.2.2: every *section start* (both ends
//!   of each run with no neighbour above or below) is tried as the first
//!   point and the shortest total is kept. The plain zig-zag is one more
//!   candidate, so MZZ is never longer than zig-zag.
//!
//! A link between consecutive runs is printed when it joins neighbouring
//! rows within two grid steps (the short slant lines of the paper's Fig. 6);
//! any other link is travel.

use serde::Serialize;

/// Which raster to fill a slice with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Fill {
    /// Alternating rows.
    Zigzag,
    /// Every row in the same direction.
    Oneway,
    /// Modified zig-zag: nearest continuation, best section start.
    Mzz,
}

impl Fill {
    /// The name used on the command line and in summaries.
    pub fn name(self) -> &'static str {
        match self {
            Fill::Zigzag => "zigzag",
            Fill::Oneway => "oneway",
            Fill::Mzz => "mzz",
        }
    }
}

/// Consecutive grid points `i0..=i1` of grid row `row` inside the region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// Grid row (along the second in-plane axis).
    pub row: i64,
    /// First grid column.
    pub i0: i64,
    /// Last grid column (≥ `i0`).
    pub i1: i64,
}

/// One run printed in a direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pass {
    /// Index into the runs.
    pub run: usize,
    /// `true`: from `i0` to `i1`.
    pub forward: bool,
}

impl Pass {
    /// `(row, column)` of the first grid point.
    pub fn start(&self, runs: &[Run]) -> (i64, i64) {
        let r = runs[self.run];
        (r.row, if self.forward { r.i0 } else { r.i1 })
    }
    /// `(row, column)` of the last grid point.
    pub fn end(&self, runs: &[Run]) -> (i64, i64) {
        let r = runs[self.run];
        (r.row, if self.forward { r.i1 } else { r.i0 })
    }
}

/// Printing and travel length of an order (mm).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Lengths {
    /// Along runs and printed links.
    pub print: f64,
    /// Non-printing links.
    pub travel: f64,
}

impl Lengths {
    /// Print + travel.
    pub fn total(&self) -> f64 {
        self.print + self.travel
    }
}

/// Grid distance between two grid points, in grid steps.
fn dist(a: (i64, i64), b: (i64, i64)) -> f64 {
    (((a.0 - b.0) as f64).powi(2) + ((a.1 - b.1) as f64).powi(2)).sqrt()
}

/// Whether a link between grid points `a` and `b` is printed.
pub fn link_printed(a: (i64, i64), b: (i64, i64)) -> bool {
    (a.0 - b.0).abs() <= 1 && dist(a, b) <= 2.0 + 1e-9
}

/// Lengths of `order` over `runs` on a grid of `spacing` mm.
pub fn lengths(runs: &[Run], order: &[Pass], spacing: f64) -> Lengths {
    let mut l = Lengths::default();
    for (k, p) in order.iter().enumerate() {
        let r = runs[p.run];
        l.print += (r.i1 - r.i0) as f64 * spacing;
        if k > 0 {
            let (a, b) = (order[k - 1].end(runs), p.start(runs));
            let d = dist(a, b) * spacing;
            if link_printed(a, b) {
                l.print += d;
            } else {
                l.travel += d;
            }
        }
    }
    l
}

/// The order in which `fill` prints `runs` (sorted by row, then column).
pub fn order(runs: &[Run], fill: Fill) -> Vec<Pass> {
    order_from(runs, fill, None)
}

/// [`order`], for a slice entered from the grid point `from` = `[column,
/// row]` (fractional; where the previous layer ended): MZZ breaks ties
/// between equally short orders by the start nearest it. Zig-zag and
/// one-way always start at the first row's first run.
pub fn order_from(runs: &[Run], fill: Fill, from: Option<[f64; 2]>) -> Vec<Pass> {
    match fill {
        Fill::Zigzag => rows(runs, true),
        Fill::Oneway => rows(runs, false),
        Fill::Mzz => mzz(runs, from),
    }
}

/// Row by row; `alternate`: odd rows (counted from the first) right to left.
fn rows(runs: &[Run], alternate: bool) -> Vec<Pass> {
    let Some(first) = runs.first() else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(runs.len());
    let mut k = 0;
    while k < runs.len() {
        let row = runs[k].row;
        let end = k + runs[k..].iter().take_while(|r| r.row == row).count();
        let reverse = alternate && (row - first.row) % 2 == 1;
        if reverse {
            out.extend((k..end).rev().map(|run| Pass {
                run,
                forward: false,
            }));
        } else {
            out.extend((k..end).map(|run| Pass { run, forward: true }));
        }
        k = end;
    }
    out
}

/// Greedy nearest continuation from every section start; the shortest wins
/// (the zig-zag order is the first candidate; ties go to the start nearest
/// `from`, then to the earlier candidate).
fn mzz(runs: &[Run], from: Option<[f64; 2]>) -> Vec<Pass> {
    if runs.is_empty() {
        return Vec::new();
    }
    let overlaps = |a: &Run, b: &Run| a.i0 <= b.i1 && b.i0 <= a.i1;
    // The runs of one row (runs are sorted by row).
    let row_runs = |row: i64| {
        let lo = runs.partition_point(|r| r.row < row);
        let hi = runs.partition_point(|r| r.row <= row);
        &runs[lo..hi]
    };
    let mut starts = Vec::new();
    for (k, r) in runs.iter().enumerate() {
        let above = row_runs(r.row - 1).iter().any(|o| overlaps(o, r));
        let below = row_runs(r.row + 1).iter().any(|o| overlaps(o, r));
        if !above || !below {
            starts.push(Pass {
                run: k,
                forward: true,
            });
            starts.push(Pass {
                run: k,
                forward: false,
            });
        }
    }
    // Bound the work on huge slices: starts × runs² ≲ 2·10⁸.
    let cap = (2e8 / (runs.len() as f64).powi(2)).max(1.0) as usize;
    if starts.len() > cap {
        let step = starts.len().div_ceil(cap);
        starts = starts.into_iter().step_by(step).collect();
    }
    // Shortest within the slice; among equally short ones, the one starting
    // nearest `from` (Sec. 2.2.2: the next layer starts near where the last
    // one ended).
    let entry = |o: &[Pass]| {
        from.map_or(0.0, |f| {
            let (row, col) = o[0].start(runs);
            ((f[0] - col as f64).powi(2) + (f[1] - row as f64).powi(2)).sqrt()
        })
    };
    let mut best = rows(runs, true);
    let mut best_len = lengths(runs, &best, 1.0).total();
    let mut best_entry = entry(&best);
    for s in starts {
        let cand = greedy(runs, s);
        let l = lengths(runs, &cand, 1.0).total();
        let e = entry(&cand);
        let tol = 1e-12 * best_len.max(1.0);
        if l < best_len - tol || (l <= best_len + tol && e < best_entry - 1e-9) {
            best = cand;
            best_len = l.min(best_len);
            best_entry = e;
        }
    }
    best
}

/// From `first`, always continue with the nearest end of an unprinted run
/// (ties: the lower run index, then forward).
fn greedy(runs: &[Run], first: Pass) -> Vec<Pass> {
    let mut done = vec![false; runs.len()];
    let mut out = Vec::with_capacity(runs.len());
    let mut cur = first;
    loop {
        done[cur.run] = true;
        out.push(cur);
        let at = cur.end(runs);
        let mut next: Option<(f64, Pass)> = None;
        for (k, r) in runs.iter().enumerate() {
            if done[k] {
                continue;
            }
            for (forward, col) in [(true, r.i0), (false, r.i1)] {
                let d = dist(at, (r.row, col));
                if next.is_none_or(|(bd, _)| d < bd - 1e-12) {
                    next = Some((d, Pass { run: k, forward }));
                }
            }
        }
        match next {
            Some((_, p)) => cur = p,
            None => return out,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A w × h block of runs with a cavity over columns c0..=c1, rows r0..=r1.
    fn block(w: i64, h: i64, cavity: Option<(i64, i64, i64, i64)>) -> Vec<Run> {
        let mut runs = Vec::new();
        for row in 0..h {
            match cavity {
                Some((c0, c1, r0, r1)) if (r0..=r1).contains(&row) => {
                    runs.push(Run {
                        row,
                        i0: 0,
                        i1: c0 - 1,
                    });
                    runs.push(Run {
                        row,
                        i0: c1 + 1,
                        i1: w - 1,
                    });
                }
                _ => runs.push(Run {
                    row,
                    i0: 0,
                    i1: w - 1,
                }),
            }
        }
        runs
    }

    fn visits_each_once(runs: &[Run], o: &[Pass]) -> bool {
        let mut seen = vec![0; runs.len()];
        o.iter().for_each(|p| seen[p.run] += 1);
        seen.iter().all(|&s| s == 1)
    }

    #[test]
    fn a_plain_block_zigzags_without_travel() {
        let runs = block(20, 10, None);
        let z = lengths(&runs, &order(&runs, Fill::Zigzag), 0.5);
        assert_eq!(z.travel, 0.0);
        assert!((z.print - (10.0 * 19.0 + 9.0) * 0.5).abs() < 1e-12);
        let m = lengths(&runs, &order(&runs, Fill::Mzz), 0.5);
        assert!((m.total() - z.total()).abs() < 1e-12);
        let o = lengths(&runs, &order(&runs, Fill::Oneway), 0.5);
        // every row but the first starts with a travel back across the block
        assert!(o.travel > 9.0 * 19.0 * 0.5, "{o:?}");
        assert!(o.total() > z.total() + 80.0, "{o:?}");
    }

    #[test]
    fn mzz_goes_round_a_cavity_instead_of_over_it() {
        let runs = block(30, 30, Some((10, 19, 5, 24)));
        let zo = order(&runs, Fill::Zigzag);
        let mo = order(&runs, Fill::Mzz);
        assert!(visits_each_once(&runs, &zo) && visits_each_once(&runs, &mo));
        let z = lengths(&runs, &zo, 1.0);
        let m = lengths(&runs, &mo, 1.0);
        // zig-zag crosses the 10-wide cavity on each of its 20 rows
        assert!(z.travel >= 20.0 * 11.0 - 1e-9, "{z:?}");
        assert!(m.total() < 0.8 * z.total(), "{m:?} vs {z:?}");
    }
}
