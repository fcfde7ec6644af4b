//! The layered graph (paper 000, Sec. III-C, Algorithm 1): one column per
//! waypoint, one node per candidate machine configuration `(tilt, C)`; an
//! edge joins every pair of nodes in neighbouring columns, weighted
//! `|Δtilt| + |ΔC|` (degrees, C unwound: the shorter way round). The
//! graph is a layered DAG, so dynamic programming over the columns finds the
//! exact shortest path (Dijkstra would find the same). Edges whose motion
//! collides are blocked; a column no unblocked edge reaches is entered
//! through a break (lift, travel, approach) at a prohibitive cost, so breaks
//! appear only where nothing else works.

use crate::kinematics::wrap;
use std::collections::HashSet;

/// Cost of a break in the toolpath, in degrees: more than any real path.
pub const BREAK_COST: f64 = 1.0e7;

/// Edge weight in degrees.
pub fn weight(a: (f64, f64), b: (f64, f64)) -> f64 {
    ((b.0 - a.0).abs() + wrap(b.1 - a.1).abs()).to_degrees()
}

/// A chosen path: node index per column and whether column `i` is entered
/// through a break.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// Node per column.
    pub nodes: Vec<usize>,
    /// `breaks[i]`: the move into column `i` is a break (never for column 0).
    pub breaks: Vec<bool>,
    /// Total weight, breaks included.
    pub cost: f64,
}

/// Shortest path through `cols` (each a list of `(tilt, c)`), avoiding the
/// `blocked` edges `(column of the edge's end, from node, to node)`.
pub fn shortest_path(cols: &[Vec<(f64, f64)>], blocked: &HashSet<(usize, usize, usize)>) -> Path {
    shortest_path_with(cols, &|i, k, j| blocked.contains(&(i, k, j)))
}

/// [`shortest_path`] with the blocked edges given by a predicate.
fn shortest_path_with(
    cols: &[Vec<(f64, f64)>],
    blocked: &dyn Fn(usize, usize, usize) -> bool,
) -> Path {
    if cols.is_empty() {
        return Path {
            nodes: Vec::new(),
            breaks: Vec::new(),
            cost: 0.0,
        };
    }
    let mut cost: Vec<Vec<f64>> = vec![vec![0.0; cols[0].len()]];
    let mut from: Vec<Vec<(usize, bool)>> = vec![vec![(0, false); cols[0].len()]];
    for i in 1..cols.len() {
        let prev = &cost[i - 1];
        // Cheapest predecessor for a break: any node, plus the penalty.
        let (bk, bc) =
            prev.iter().enumerate().fold(
                (0, f64::INFINITY),
                |acc, (k, &c)| if c < acc.1 { (k, c) } else { acc },
            );
        let mut ci = Vec::with_capacity(cols[i].len());
        let mut fi = Vec::with_capacity(cols[i].len());
        for (j, &b) in cols[i].iter().enumerate() {
            let mut best = (bc + BREAK_COST, (bk, true));
            for (k, &a) in cols[i - 1].iter().enumerate() {
                if blocked(i, k, j) {
                    continue;
                }
                let c = prev[k] + weight(a, b);
                if c < best.0 {
                    best = (c, (k, false));
                }
            }
            ci.push(best.0);
            fi.push(best.1);
        }
        cost.push(ci);
        from.push(fi);
    }
    let last = cols.len() - 1;
    let (mut j, total) = cost[last]
        .iter()
        .enumerate()
        .fold(
            (0, f64::INFINITY),
            |acc, (k, &c)| if c < acc.1 { (k, c) } else { acc },
        );
    let mut nodes = vec![0; cols.len()];
    let mut breaks = vec![false; cols.len()];
    for i in (0..cols.len()).rev() {
        nodes[i] = j;
        if i > 0 {
            let (k, br) = from[i][j];
            breaks[i] = br;
            j = k;
        }
    }
    Path {
        nodes,
        breaks,
        cost: total,
    }
}

/// Paper 002's heuristic 2 (interval subsampling) for very long paths:
/// solve the graph of every `k`-th column (and the last) with direct edges,
/// then each interval between two chosen nodes on its own. Cheaper on
/// memory, never cheaper in cost than [`shortest_path`]; `k ≤ 1` is exact.
pub fn shortest_path_subsampled(
    cols: &[Vec<(f64, f64)>],
    blocked: &HashSet<(usize, usize, usize)>,
    k: usize,
) -> Path {
    let last = cols.len().saturating_sub(1);
    if k <= 1 || cols.len() <= k + 1 {
        return shortest_path(cols, blocked);
    }
    let mut picks: Vec<usize> = (0..cols.len()).step_by(k).collect();
    if picks.last() != Some(&last) {
        picks.push(last);
    }
    let coarse_cols: Vec<Vec<(f64, f64)>> = picks.iter().map(|&i| cols[i].clone()).collect();
    let coarse = shortest_path(&coarse_cols, &HashSet::new());
    let mut nodes = vec![0; cols.len()];
    let mut breaks = vec![false; cols.len()];
    let mut cost = 0.0;
    for m in 0..picks.len() - 1 {
        let (a, b) = (picks[m], picks[m + 1]);
        let (na, nb) = (coarse.nodes[m], coarse.nodes[m + 1]);
        // The interval with its ends pinned to the coarse choice; local node
        // 0 of the end columns stands for the pinned node.
        let sub: Vec<Vec<(f64, f64)>> = (a..=b)
            .map(|i| match i {
                _ if i == a => vec![cols[a][na]],
                _ if i == b => vec![cols[b][nb]],
                _ => cols[i].clone(),
            })
            .collect();
        let global = |i: usize, n: usize| {
            if i == a {
                na
            } else if i == b {
                nb
            } else {
                n
            }
        };
        let p = shortest_path_with(&sub, &|l, kk, j| {
            blocked.contains(&(a + l, global(a + l - 1, kk), global(a + l, j)))
        });
        for (l, &n) in p.nodes.iter().enumerate() {
            nodes[a + l] = global(a + l, n);
            if l > 0 {
                breaks[a + l] = p.breaks[l];
            }
        }
        cost += p.cost;
    }
    Path {
        nodes,
        breaks,
        cost,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(cols: &[Vec<(f64, f64)>], blocked: &HashSet<(usize, usize, usize)>) -> f64 {
        fn go(
            cols: &[Vec<(f64, f64)>],
            blocked: &HashSet<(usize, usize, usize)>,
            i: usize,
            prev: usize,
            acc: f64,
            best: &mut f64,
        ) {
            if i == cols.len() {
                *best = best.min(acc);
                return;
            }
            for j in 0..cols[i].len() {
                let w = if blocked.contains(&(i, prev, j)) {
                    BREAK_COST
                } else {
                    weight(cols[i - 1][prev], cols[i][j])
                };
                go(cols, blocked, i + 1, j, acc + w, best);
            }
        }
        let mut best = f64::INFINITY;
        for j in 0..cols[0].len() {
            go(cols, blocked, 1, j, 0.0, &mut best);
        }
        best
    }

    #[test]
    fn dp_matches_brute_force_enumeration() {
        let mut s = 99u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as f64 / (1u64 << 31) as f64
        };
        for _ in 0..200 {
            let n = 2 + (rnd() * 5.0) as usize;
            let cols: Vec<Vec<(f64, f64)>> = (0..n)
                .map(|_| {
                    (0..1 + (rnd() * 4.0) as usize)
                        .map(|_| (rnd() * 2.0 - 1.0, rnd() * 7.0 - 3.5))
                        .collect()
                })
                .collect();
            let mut blocked = HashSet::new();
            for i in 1..n {
                for k in 0..cols[i - 1].len() {
                    for j in 0..cols[i].len() {
                        if rnd() < 0.3 {
                            blocked.insert((i, k, j));
                        }
                    }
                }
            }
            let p = shortest_path(&cols, &blocked);
            let b = brute(&cols, &blocked);
            assert!(
                (p.cost - b).abs() < 1e-6 * b.max(1.0),
                "dp {} brute {}",
                p.cost,
                b
            );
            // The path's own cost adds up.
            let mut c = 0.0;
            for i in 1..n {
                c += if p.breaks[i] {
                    BREAK_COST
                } else {
                    weight(cols[i - 1][p.nodes[i - 1]], cols[i][p.nodes[i]])
                };
                if !p.breaks[i] {
                    assert!(!blocked.contains(&(i, p.nodes[i - 1], p.nodes[i])));
                }
            }
            assert!((c - p.cost).abs() < 1e-6 * c.max(1.0));
            // Subsampling: never cheaper than exact, a valid path, exact at k = 1.
            for k in [1, 2, 3] {
                let s = shortest_path_subsampled(&cols, &blocked, k);
                assert_eq!(s.nodes.len(), n);
                assert!(
                    s.cost >= p.cost - 1e-6 * p.cost.max(1.0),
                    "k {k}: {} < {}",
                    s.cost,
                    p.cost
                );
                if k == 1 {
                    assert!((s.cost - p.cost).abs() < 1e-6 * p.cost.max(1.0));
                }
                let mut c = 0.0;
                for i in 1..n {
                    c += if s.breaks[i] {
                        BREAK_COST
                    } else {
                        weight(cols[i - 1][s.nodes[i - 1]], cols[i][s.nodes[i]])
                    };
                    if !s.breaks[i] {
                        assert!(!blocked.contains(&(i, s.nodes[i - 1], s.nodes[i])));
                    }
                }
                assert!(
                    (c - s.cost).abs() < 1e-6 * c.max(1.0),
                    "k {k}: path cost {c} vs reported {}",
                    s.cost
                );
            }
        }
    }
}
