//! The layered graph of one section and its shortest path (paper 000,
//! Sec. III-C, Algorithm 1): one column per waypoint, one node per
//! candidate machine configuration; an edge joins every pair of nodes in
//! neighbouring columns. Between two neighbours the machine either prints
//! (cost [`CostModel::print_cost`]: the rotation, plus the blob when the
//! extruder cannot follow it) or breaks off (cost
//! [`CostModel::break_cost`]: the rotation plus the time of retract, lift,
//! approach and prime); the search takes whichever is cheaper, so breaks
//! are priced, not a last resort. Edges whose printing motion collides are
//! blocked, leaving only the break between those two nodes. The graph is a
//! layered DAG, so dynamic programming over the columns finds the exact
//! shortest path. Stage 4 (`graph`) solves it section by section
//! as it learns which nodes and edges are free.

use super::cost::CostModel;
use crate::kinematics::Axes;
use rustc_hash::FxHashSet as HashSet;
use std::ops::Range;

/// A chosen path: node index per column and whether column `i` is entered
/// through a break.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Path {
    /// Node per column.
    pub nodes: Vec<usize>,
    /// `breaks[i]`: the move into column `i` is a break (never for column 0).
    pub breaks: Vec<bool>,
    /// Total cost (degrees).
    pub cost: f64,
}

/// The columns of one section: candidate configurations per waypoint and
/// the bead length from each waypoint to the next.
#[derive(Clone, Copy)]
pub struct SectionGraph<'a> {
    /// Candidate configurations per column.
    pub configs: &'a [Vec<Axes>],
    /// `lens[i]`: bead length from column `i` to column `i + 1` (mm).
    pub lens: &'a [f64],
    /// Edge costs.
    pub cost: &'a CostModel,
    /// Whether node `j` of column `i` may be on a path (a node whose pose
    /// was found to collide stays in its column, so that indices keep
    /// their meaning, but is never taken). Every column must keep one.
    pub live: &'a (dyn Fn(usize, usize) -> bool + Sync),
}

/// Every node may be on a path.
pub fn all_live(_: usize, _: usize) -> bool {
    true
}

/// Printing edges `(column of the edge's end, from node, to node)`.
pub type EdgeSet = HashSet<(usize, usize, usize)>;

/// What the search knows of printing edges: which collide (only the break
/// is left between those two nodes) and which are proven free (so they are
/// not proven again).
#[derive(Clone, Debug, Default)]
pub struct KnownEdges {
    /// Printing edges whose motion collides.
    pub blocked: EdgeSet,
    /// Printing edges proven free.
    pub proven: EdgeSet,
}

/// Shortest path through the columns avoiding the blocked printing edges
/// (breaks stay possible everywhere).
pub fn shortest_path(g: SectionGraph, edges: &KnownEdges) -> Path {
    shortest_path_with(g.configs, g.lens, g.cost, g.live, &|i, k, j| {
        edges.blocked.contains(&(i, k, j))
    })
}

/// `path` with only the columns in `window` solved again (after edges in
/// it were blocked): the window's end columns keep the path's nodes unless
/// they are the section's ends, so what lies outside stays as it was, and
/// proven. Blocking one edge then costs proving a few new ones, not a new
/// path through the whole section.
pub fn repair(g: SectionGraph, edges: &KnownEdges, path: &Path, window: Range<usize>) -> Path {
    let last = g.configs.len() - 1;
    let (a, b) = (window.start, window.end.min(last + 1) - 1);
    let pinned = |i: usize| (i == a && a > 0) || (i == b && b < last);
    let sub: Vec<Vec<Axes>> = (a..=b)
        .map(|i| {
            if pinned(i) {
                vec![g.configs[i][path.nodes[i]]]
            } else {
                g.configs[i].clone()
            }
        })
        .collect();
    let global = |i: usize, n: usize| if pinned(i) { path.nodes[i] } else { n };
    let live = |l: usize, j: usize| (g.live)(a + l, global(a + l, j));
    let p = shortest_path_with(&sub, &g.lens[a..b], g.cost, &live, &|l, k, j| {
        edges
            .blocked
            .contains(&(a + l, global(a + l - 1, k), global(a + l, j)))
    });
    let mut out = path.clone();
    for (l, &n) in p.nodes.iter().enumerate() {
        out.nodes[a + l] = global(a + l, n);
        if l > 0 {
            out.breaks[a + l] = p.breaks[l];
        }
    }
    out.cost = path_cost(g, &out);
    out
}

/// The cost of `path` from its own moves.
pub fn path_cost(g: SectionGraph, p: &Path) -> f64 {
    (1..g.configs.len())
        .map(|i| {
            let (a, b) = (&g.configs[i - 1][p.nodes[i - 1]], &g.configs[i][p.nodes[i]]);
            if p.breaks[i] {
                g.cost.break_cost(g.lens[i - 1], a, b)
            } else {
                g.cost.print_cost(g.lens[i - 1], a, b)
            }
        })
        .sum()
}

/// [`shortest_path`] with the live nodes and the blocked edges given by
/// predicates.
fn shortest_path_with(
    configs: &[Vec<Axes>],
    lens: &[f64],
    cm: &CostModel,
    live: &dyn Fn(usize, usize) -> bool,
    blocked: &dyn Fn(usize, usize, usize) -> bool,
) -> Path {
    solve_columns(configs, live, |i, j, cost| {
        let (len, b) = (lens[i - 1], &configs[i][j]);
        let beyond = cm.break_beyond_rotation(len);
        let mut best = (f64::INFINITY, (0, true));
        for (k, a) in configs[i - 1].iter().enumerate() {
            let before = cost[k];
            if before == f64::INFINITY {
                continue; // Dead, or not reachable.
            }
            // Neither move costs less than its rotation: a node that
            // cannot reach the best that way is passed over before the
            // dwell and the blocked edges are looked up.
            let r = cm.rotation_deg(a, b);
            let floor = before + r;
            if floor > best.0 {
                continue;
            }
            let c = before + (r + beyond);
            if c < best.0 {
                best = (c, (k, true));
            }
            // (The break costs `floor` or more: the best is still no less.)
            let c = before + cm.print_cost_turning(r, len, a, b);
            if c <= best.0 && !blocked(i, k, j) {
                best = (c, (k, false));
            }
        }
        best
    })
}

/// The dynamic programme over the columns: column 0's live nodes cost
/// nothing, node `j` of column `i` is entered the way `best_into(i, j,
/// costs of column i − 1)` finds cheapest (its cost, the node before it,
/// whether that move is a break), dead nodes not at all; then the path is
/// followed back from the last column's cheapest node.
fn solve_columns(
    configs: &[Vec<Axes>],
    live: &dyn Fn(usize, usize) -> bool,
    best_into: impl Fn(usize, usize, &[f64]) -> (f64, (usize, bool)),
) -> Path {
    if configs.is_empty() {
        return Path {
            nodes: Vec::new(),
            breaks: Vec::new(),
            cost: 0.0,
        };
    }
    let mut cost: Vec<f64> = (0..configs[0].len())
        .map(|j| if live(0, j) { 0.0 } else { f64::INFINITY })
        .collect();
    let mut from: Vec<Vec<(usize, bool)>> = vec![vec![(0, false); configs[0].len()]];
    for (i, column) in configs.iter().enumerate().skip(1) {
        let (ci, fi): (Vec<f64>, Vec<(usize, bool)>) = (0..column.len())
            .map(|j| {
                if live(i, j) {
                    best_into(i, j, &cost)
                } else {
                    (f64::INFINITY, (0, true))
                }
            })
            .unzip();
        cost = ci;
        from.push(fi);
    }
    trace_back(&cost, &from)
}

/// The path ending at the cheapest node of the last column (`cost`),
/// followed back through `from` (per column and node: the node before it
/// and whether the move into it is a break).
fn trace_back(cost: &[f64], from: &[Vec<(usize, bool)>]) -> Path {
    let (mut j, total) =
        cost.iter().enumerate().fold(
            (0, f64::INFINITY),
            |acc, (k, &c)| if c < acc.1 { (k, c) } else { acc },
        );
    let mut nodes = vec![0; from.len()];
    let mut breaks = vec![false; from.len()];
    for i in (0..from.len()).rev() {
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
/// solve the graph of every `k`-th column (and the last) with the direct
/// moves between them, then each interval between two chosen nodes on its
/// own. Never cheaper than [`shortest_path`]; `k ≤ 1` is exact.
pub fn shortest_path_subsampled(g: SectionGraph, blocked: &KnownEdges, k: usize) -> Path {
    let configs = g.configs;
    let last = configs.len().saturating_sub(1);
    if k <= 1 || configs.len() <= k + 1 {
        return shortest_path(g, blocked);
    }
    let mut picks: Vec<usize> = (0..configs.len()).step_by(k).collect();
    if picks.last() != Some(&last) {
        picks.push(last);
    }
    let coarse_configs: Vec<Vec<Axes>> = picks.iter().map(|&i| configs[i].clone()).collect();
    let coarse_lens: Vec<f64> = picks
        .windows(2)
        .map(|w| g.lens[w[0]..w[1]].iter().sum())
        .collect();
    let coarse_live = |m: usize, j: usize| (g.live)(picks[m], j);
    let coarse = shortest_path_with(
        &coarse_configs,
        &coarse_lens,
        g.cost,
        &coarse_live,
        &|_, _, _| false,
    );
    let mut nodes = vec![0; configs.len()];
    let mut breaks = vec![false; configs.len()];
    let mut cost = 0.0;
    for m in 0..picks.len() - 1 {
        let (a, b) = (picks[m], picks[m + 1]);
        let (na, nb) = (coarse.nodes[m], coarse.nodes[m + 1]);
        // The interval with its ends pinned to the coarse choice; local node
        // 0 of the end columns stands for the pinned node.
        let sub: Vec<Vec<Axes>> = (a..=b)
            .map(|i| match i {
                _ if i == a => vec![configs[a][na]],
                _ if i == b => vec![configs[b][nb]],
                _ => configs[i].clone(),
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
        let live = |l: usize, j: usize| (g.live)(a + l, global(a + l, j));
        let p = shortest_path_with(&sub, &g.lens[a..b], g.cost, &live, &|l, kk, j| {
            blocked
                .blocked
                .contains(&(a + l, global(a + l - 1, kk), global(a + l, j)))
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
    use crate::kinematics::Machine;

    /// Each node found colliding with probability `p`, every column
    /// keeping its last one.
    fn random_dead(cols: &[Vec<Axes>], p: f64, rnd: &mut impl FnMut() -> f64) -> Vec<Vec<bool>> {
        cols.iter()
            .map(|c| (0..c.len()).map(|j| j + 1 < c.len() && rnd() < p).collect())
            .collect()
    }

    /// Each printing edge blocked with probability `p`.
    fn random_blocked(cols: &[Vec<Axes>], p: f64, rnd: &mut impl FnMut() -> f64) -> EdgeSet {
        let mut blocked = EdgeSet::default();
        for i in 1..cols.len() {
            for k in 0..cols[i - 1].len() {
                for j in 0..cols[i].len() {
                    if rnd() < p {
                        blocked.insert((i, k, j));
                    }
                }
            }
        }
        blocked
    }

    fn brute(g: SectionGraph, blocked: &EdgeSet) -> f64 {
        fn go(g: SectionGraph, blocked: &EdgeSet, i: usize, prev: usize, acc: f64, best: &mut f64) {
            if i == g.configs.len() {
                *best = best.min(acc);
                return;
            }
            for j in 0..g.configs[i].len() {
                if !(g.live)(i, j) {
                    continue;
                }
                let (a, b) = (&g.configs[i - 1][prev], &g.configs[i][j]);
                let mut w = g.cost.break_cost(g.lens[i - 1], a, b);
                if !blocked.contains(&(i, prev, j)) {
                    w = w.min(g.cost.print_cost(g.lens[i - 1], a, b));
                }
                go(g, blocked, i + 1, j, acc + w, best);
            }
        }
        let mut best = f64::INFINITY;
        for j in 0..g.configs[0].len() {
            if (g.live)(0, j) {
                go(g, blocked, 1, j, 0.0, &mut best);
            }
        }
        best
    }

    #[test]
    fn dp_matches_brute_force_enumeration() {
        let m = Machine::default();
        let cm = CostModel::new(&m, m.feed, m.tip_speed, 10.0);
        let mut s = 99u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as f64 / (1u64 << 31) as f64
        };
        for _ in 0..200 {
            let n = 2 + (rnd() * 5.0) as usize;
            let cols: Vec<Vec<Axes>> = (0..n)
                .map(|i| {
                    (0..1 + (rnd() * 4.0) as usize)
                        .map(|_| {
                            m.axes_at(
                                [10.0 + 0.6 * i as f64, 2.0, 45.0],
                                (rnd() * 2.0 - 1.0, rnd() * 6.2 - 3.1),
                            )
                        })
                        .collect()
                })
                .collect();
            let lens: Vec<f64> = (0..n).map(|_| rnd() * 2.0).collect();
            // A quarter of the nodes found colliding.
            let dead = random_dead(&cols, 0.25, &mut rnd);
            let live = |i: usize, j: usize| !dead[i][j];
            let g = SectionGraph {
                configs: &cols,
                lens: &lens,
                cost: &cm,
                live: &live,
            };
            let blocked = random_blocked(&cols, 0.3, &mut rnd);
            let edges = KnownEdges {
                blocked: blocked.clone(),
                proven: EdgeSet::default(),
            };
            let p = shortest_path(g, &edges);
            let b = brute(g, &blocked);
            assert!(
                (p.cost - b).abs() < 1e-6 * b.max(1.0),
                "dp {} brute {}",
                p.cost,
                b
            );
            assert!((path_cost(g, &p) - p.cost).abs() < 1e-6 * p.cost.max(1.0));
            let alive = |path: &Path| (0..n).all(|i| live(i, path.nodes[i]));
            assert!(alive(&p), "a dead node on the path");
            for i in 1..n {
                if !p.breaks[i] {
                    assert!(!blocked.contains(&(i, p.nodes[i - 1], p.nodes[i])));
                }
            }
            // Repairing a window of a path whose edges in it get blocked:
            // a valid path avoiding them, unchanged outside the window,
            // never cheaper than solving anew.
            if n >= 4 {
                let mut more = edges.clone();
                for i in 2..n - 1 {
                    more.blocked.insert((i, p.nodes[i - 1], p.nodes[i]));
                }
                let r = repair(g, &more, &p, 1..n - 1);
                assert!((path_cost(g, &r) - r.cost).abs() < 1e-6 * r.cost.max(1.0));
                assert!(alive(&r), "a dead node on the repaired path");
                assert_eq!(r.nodes[0], p.nodes[0]);
                assert_eq!(r.nodes[n - 1], p.nodes[n - 1]);
                let fresh = shortest_path(g, &more);
                assert!(r.cost >= fresh.cost - 1e-6 * fresh.cost.max(1.0));
                for i in 1..n {
                    if !r.breaks[i] {
                        assert!(!more.blocked.contains(&(i, r.nodes[i - 1], r.nodes[i])));
                    }
                }
            }
            // Subsampling: never cheaper than exact, a valid path, exact at k = 1.
            for k in [1, 2, 3] {
                let s = shortest_path_subsampled(g, &edges, k);
                assert_eq!(s.nodes.len(), n);
                assert!(s.cost >= p.cost - 1e-6 * p.cost.max(1.0), "k {k}");
                assert!(alive(&s), "a dead node on the subsampled path");
                if k == 1 {
                    assert!((s.cost - p.cost).abs() < 1e-6 * p.cost.max(1.0));
                }
                assert!((path_cost(g, &s) - s.cost).abs() < 1e-6 * s.cost.max(1.0));
                for i in 1..n {
                    if !s.breaks[i] {
                        assert!(!blocked.contains(&(i, s.nodes[i - 1], s.nodes[i])));
                    }
                }
            }
        }
    }

    /// The DP without the pruning: every pair of nodes costed both ways.
    fn unpruned(g: SectionGraph, blocked: &EdgeSet) -> Path {
        solve_columns(g.configs, g.live, |i, j, cost| {
            let (len, b) = (g.lens[i - 1], &g.configs[i][j]);
            let mut best = (f64::INFINITY, (0, true));
            for (k, a) in g.configs[i - 1].iter().enumerate() {
                if cost[k] == f64::INFINITY {
                    continue;
                }
                let c = cost[k] + g.cost.break_cost(len, a, b);
                if c < best.0 {
                    best = (c, (k, true));
                }
                let c = cost[k] + g.cost.print_cost(len, a, b);
                if !blocked.contains(&(i, k, j)) && c <= best.0 {
                    best = (c, (k, false));
                }
            }
            best
        })
    }

    /// Passing over the nodes whose rotation alone exceeds the best leaves
    /// the path node for node what costing every pair gives, ties
    /// included: columns repeat configurations, turn a whole way round (a
    /// free C's rotation is 0 to its twin) and keep nodes that dwell.
    #[test]
    fn pruning_keeps_the_unpruned_path_ties_included() {
        let m = Machine::default();
        let cm = CostModel::new(&m, m.feed, m.tip_speed, 10.0);
        let mut uniform = crate::geometry::xorshift(0x0d0e_5eed_0000_0042);
        for _ in 0..300 {
            let n = 2 + (uniform() * 12.0) as usize;
            let pool: Vec<(f64, f64)> = (0..4)
                .map(|_| (uniform() * 2.0 - 1.0, uniform() * 6.2 - 3.1))
                .collect();
            let cols: Vec<Vec<Axes>> = (0..n)
                .map(|i| {
                    (0..1 + (uniform() * 8.0) as usize)
                        .map(|_| {
                            let (tilt, c) = pool[(uniform() * 4.0) as usize];
                            let turn = if uniform() < 0.2 {
                                std::f64::consts::TAU
                            } else {
                                0.0
                            };
                            m.axes_at([10.0 + 0.6 * i as f64, 2.0, 45.0], (tilt, c + turn))
                        })
                        .collect()
                })
                .collect();
            let lens: Vec<f64> = (0..n).map(|_| 0.05 + uniform() * 2.0).collect();
            let dead = random_dead(&cols, 0.2, &mut uniform);
            let live = |i: usize, j: usize| !dead[i][j];
            let g = SectionGraph {
                configs: &cols,
                lens: &lens,
                cost: &cm,
                live: &live,
            };
            let edges = KnownEdges {
                blocked: random_blocked(&cols, 0.2, &mut uniform),
                proven: EdgeSet::default(),
            };
            let p = shortest_path(g, &edges);
            assert_eq!(p, unpruned(g, &edges.blocked));
        }
    }

    #[test]
    fn a_swing_the_extruder_cannot_follow_becomes_a_break() {
        let m = Machine::default();
        let cm = CostModel::new(&m, m.feed, m.tip_speed, 10.0);
        // Column 1 offers only a configuration 150° of C away: printing into
        // it over 0.5 mm would dwell ~11 s; the break is cheaper.
        let p = |x: f64| [x, 5.0, 45.0];
        let cols = vec![
            vec![m.axes_at(p(0.0), (0.4, 0.0))],
            vec![m.axes_at(p(0.5), (0.4, 150f64.to_radians()))],
            vec![m.axes_at(p(1.0), (0.4, 150f64.to_radians()))],
        ];
        let lens = vec![0.5, 0.5];
        let g = SectionGraph {
            configs: &cols,
            lens: &lens,
            cost: &cm,
            live: &all_live,
        };
        let path = shortest_path(g, &KnownEdges::default());
        assert_eq!(path.breaks, vec![false, true, false]);
    }
}
