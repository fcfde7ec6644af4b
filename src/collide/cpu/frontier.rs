//! The cpu backend's own tree walk (no WGSL twin: the kernels walk as
//! `collide_traverse.wgsl` does, mirrored step for step by
//! [`super::traverse`]). One walk (`walk`) serves both ways the backend
//! asks: [`first_hit`] is it from the root, keeping nothing, and a
//! worker's [`Frontier`] is it from the cut of the tree its last query
//! stopped at. It tests each undecided triangle on the spot ([`leaf_hit`])
//! and stops at the first hit, where the kernels hand undecided pairs to a
//! second pass; the verdict is the same (`tests/differential.rs`).
//!
//! A walk that finds no hit stops at a *cut* of the tree: nodes it skipped
//! as clear of the head (by their sphere or their slab), nodes printed
//! after its cutoff, and the leaves it tested. Every triangle lies below
//! exactly one of them. The planner asks neighbouring poses in a row (a
//! move's samples, a layer's waypoints), so the next query starts from
//! that cut instead of the root: a node skipped as clear by `d` mm at the
//! last pose is still clear at this one when the head moved less than
//! `d` minus this query's margin there — a point `ρ` from the old tip
//! moves, seen from the head, at most `|Δtip| + ‖ΔR‖ ρ` (`‖ΔR‖` the
//! spectral norm of the difference of the two rotations, [`turn_bound`]:
//! the Frobenius norm over √2). Such nodes, and nodes printed after the
//! last cutoff when this one is no later (a move's samples share theirs),
//! cost a comparison instead of a grid lookup, and the walk down to them
//! is not repeated; every other cut node is walked again exactly as from
//! the root. A cut only ever gets finer (a node walked again leaves its
//! children in it, where a walk from the root would now skip their
//! parent), so once it has grown by half over the last free walk's from the
//! root, the next walk starts from the root again: cuts that are never
//! reset grow to many times the root's and cost more than they save. A
//! hit ends the walk early; its cut is what the walk settled, plus the
//! node that hit and the nodes it had yet to walk, to be walked again
//! (the next query, often a neighbour of a colliding one, would
//! otherwise start from the root: a third of the columns' work).

use super::common::{
    grid_sample, head_tri, node_hull_gap_of, slab_gap_of, sphere_margin, to_head, tri_hits_exact,
    SceneView, STACK_SIZE,
};
use crate::geometry::{length, V3};
use crate::scene::{GpuHeadParams, GpuQuery, GpuTriangle};

/// Does the head at query `q` touch, contain or come closer than `q.margin`
/// to anything with `stamp < cutoff`?
pub fn query_hits(s: &SceneView, q: &GpuQuery) -> bool {
    first_hit(s, q).is_some()
}

/// What [`first_hit`] names when a whole node lies inside the head.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// [`query_hits`], naming what decided it: the first triangle (index into
/// the part triangles) that hits, or [`NO_TRIANGLE`] when a node wholly
/// inside the head did. `walk` from the root, its cut kept nowhere.
pub fn first_hit(s: &SceneView, q: &GpuQuery) -> Option<u32> {
    walk(s, q, 0, &mut [0; STACK_SIZE], &mut NoCut)
}

/// The first triangle of the leaf `first..first + count` that exists at
/// `q`'s cutoff and hits the head.
#[inline(always)]
pub fn leaf_hit(s: &SceneView, q: &GpuQuery, first: u32, count: u32) -> Option<u32> {
    (first..first + count).find(|&t| {
        let tri = &s.tris[t as usize];
        tri.stamp < q.cutoff && tri_hits(s, q, tri)
    })
}

/// One existing part triangle against the head: the grid and the hull
/// plane ([`head_tri`], as the kernel walk classifies it), then,
/// when they cannot tell, the exact tests (as the exact kernel does).
#[inline(always)]
pub fn tri_hits(s: &SceneView, q: &GpuQuery, tri: &GpuTriangle) -> bool {
    let h = head_tri(s, q, tri);
    if h.cls != 0 {
        return h.cls < 0;
    }
    tri_hits_exact(s, h.a, h.b, h.c, h.margin)
}

/// One node of a cut: its index, how far its sphere (or slab) is known
/// to be from the head (`< 0`: nothing known — walk it again, unless
/// [`AFTER_CUTOFF`] and the cutoff has not risen), and the
/// largest distance of its points from the tip (`|c| + r`, head frame),
/// both at the cut's pose.
#[derive(Clone, Copy, Debug)]
pub(super) struct Cut {
    node: u32,
    clear: f32,
    reach: f32,
}

/// The `clear` of a cut node printed after its query's cutoff: it stays
/// so for a query whose cutoff is no later.
const AFTER_CUTOFF: f32 = -2.0;

/// A worker's last cut and the pose it was found at.
#[derive(Default)]
pub struct Frontier {
    rows: Option<[[f32; 4]; 3]>,
    /// The cutoff of the query the cut was found for.
    cutoff: u32,
    cut: Vec<Cut>,
    next: Vec<Cut>,
    /// The size of the last cut a free walk from the root left.
    from_root: usize,
    /// Cut nodes carried over without a look at the grid, so far.
    carried: u64,
    /// Of those, nodes printed after the cutoff.
    carried_after_cutoff: u64,
    /// Queries walked from the cut a hit left.
    after_hit: u64,
    /// Whether the last query hit.
    hit: bool,
    /// Queries asked of it.
    walks: u64,
}

impl Frontier {
    /// [`first_hit`] for `q`, from the last cut when there is one; the
    /// verdict is the same.
    pub fn first_hit(&mut self, s: &SceneView, q: &GpuQuery) -> Option<u32> {
        self.next.clear();
        let mut stack = [0u32; STACK_SIZE];
        let prev = self
            .rows
            .filter(|_| 2 * self.cut.len() <= 3 * self.from_root + 32);
        let hit = match prev {
            None => {
                let hit = walk(s, q, 0, &mut stack, &mut self.next);
                if hit.is_none() {
                    self.from_root = self.next.len();
                }
                hit
            }
            Some(prev) => {
                self.after_hit += self.hit as u64;
                self.walk_cut(s, q, &prev, &mut stack)
            }
        };
        self.hit = hit.is_some();
        self.walks += 1;
        self.rows = Some(q.rows);
        self.cutoff = q.cutoff;
        std::mem::swap(&mut self.cut, &mut self.next);
        hit
    }

    /// Queries asked of it so far.
    #[cfg(test)]
    pub(super) fn walks(&self) -> u64 {
        self.walks
    }

    fn walk_cut(
        &mut self,
        s: &SceneView,
        q: &GpuQuery,
        prev: &[[f32; 4]; 3],
        stack: &mut [u32; STACK_SIZE],
    ) -> Option<u32> {
        let (moved, turned) = motion(prev, &q.rows);
        for k in 0..self.cut.len() {
            let e = self.cut[k].seen_from(q, self.cutoff, moved, turned);
            if e.clear == AFTER_CUTOFF {
                self.next.push(e);
                self.carried += 1;
                self.carried_after_cutoff += 1;
                continue;
            }
            if e.clear >= 0.0 {
                let margin = if q.slope > 0.0 {
                    q.margin + q.slope * e.reach
                } else {
                    q.margin
                };
                if e.clear - s.head.grid_slack > margin {
                    self.next.push(e);
                    self.carried += 1;
                    continue;
                }
            }
            let hit = walk(s, q, e.node, stack, &mut self.next);
            if hit.is_some() {
                for e in &self.cut[k + 1..] {
                    self.next.push(e.seen_from(q, self.cutoff, moved, turned));
                }
                return hit;
            }
        }
        None
    }
}

impl Cut {
    /// This node of the cut found at the last query's pose (its cutoff
    /// `cutoff`) as a node of a cut at `q`'s, the head having moved
    /// `moved` and turned `turned` in between: what it knows still holds,
    /// less the motion. A walk from the cut carries it so when that
    /// leaves it clear by more than `q`'s margin; a hit keeps the nodes
    /// it did not look at so.
    #[inline(always)]
    fn seen_from(self, q: &GpuQuery, cutoff: u32, moved: f32, turned: f32) -> Cut {
        if self.clear == AFTER_CUTOFF && q.cutoff <= cutoff {
            return self;
        }
        if self.clear >= 0.0 {
            let d = moved + turned * self.reach;
            if self.clear - d >= 0.0 {
                return Cut {
                    node: self.node,
                    clear: self.clear - d,
                    reach: self.reach + d,
                };
            }
        }
        again(self.node)
    }
}

/// A cut node to be walked again.
fn again(node: u32) -> Cut {
    Cut {
        node,
        clear: -1.0,
        reach: 0.0,
    }
}

/// How far the tip moved and a bound on how far the rotation turned a
/// unit vector ([`turn_bound`]), rounded up.
fn motion(a: &[[f32; 4]; 3], b: &[[f32; 4]; 3]) -> (f32, f32) {
    let mut t = 0.0f32;
    let mut r = 0.0f32;
    for i in 0..3 {
        let d = b[i][3] - a[i][3];
        t += d * d;
        for j in 0..3 {
            let d = b[i][j] - a[i][j];
            r += d * d;
        }
    }
    // A few ulps for the rounding of the sums and the square roots.
    let frobenius = r.sqrt() * UP + 1e-6;
    (t.sqrt() * UP, turn_bound(a, b, frobenius))
}

/// `1 + 8 ε`: a product or a sum of a few terms rounded up.
const UP: f32 = 1.0 + 8.0 * f32::EPSILON;

/// A bound on `‖A − B‖₂`, the most the frames `a` and `b` (the queries'
/// 3×3 parts) move a unit vector apart, given `frobenius ≥ ‖A − B‖_F`.
///
/// For rotations `A`, `B`, `A − B = A (I − AᵀB)` and `AᵀB` turns by some
/// angle `θ`: `I − AᵀB` has the singular values `2 sin(θ/2)` twice and 0,
/// so `‖A − B‖₂ = ‖A − B‖_F / √2` — the Frobenius norm alone overstates
/// the turn by √2. The f32 frames are orthogonal only within rounding:
/// with `Q` the orthogonal matrix nearest `A` (polar decomposition),
/// `‖A − Q‖_F ≤ e(A) = ‖A Aᵀ − I‖_F` (each singular value `σ` has
/// `|σ − 1| ≤ |σ² − 1|`), so `‖A − B‖₂ ≤ ‖Q_A − Q_B‖_F / √2 + e(A) +
/// e(B) ≤ ‖A − B‖_F / √2 + (1 + 1/√2)(e(A) + e(B))` when `Q_AᵀQ_B` is a
/// rotation (both determinants of one sign). Frames far from orthogonal,
/// or of opposite handedness, keep the Frobenius norm, which bounds the
/// spectral norm of any matrix.
fn turn_bound(a: &[[f32; 4]; 3], b: &[[f32; 4]; 3], frobenius: f32) -> f32 {
    let (Some((ea, ra)), Some((eb, rb))) = (frame_defect(a), frame_defect(b)) else {
        return frobenius;
    };
    if ra != rb {
        return frobenius;
    }
    let spectral = frobenius * std::f32::consts::FRAC_1_SQRT_2 * UP + 1.7072 * (ea + eb) * UP;
    spectral.min(frobenius)
}

/// How far the frame `m` (its 3×3 part) is from orthogonal — `‖M Mᵀ −
/// I‖_F`, rounded up (each entry of `M Mᵀ` is within a few ulps of 1 in
/// f32) — and whether it keeps handedness (`det M > 0`); `None` when it
/// is not near orthogonal (then the sign of a rounded determinant is not
/// to be trusted either).
fn frame_defect(m: &[[f32; 4]; 3]) -> Option<(f32, bool)> {
    let row = |i: usize| [m[i][0], m[i][1], m[i][2]];
    let mut s = 0.0f32;
    for i in 0..3 {
        for j in 0..3 {
            let (p, q) = (row(i), row(j));
            let g = p[0] * q[0] + p[1] * q[1] + p[2] * q[2] - if i == j { 1.0 } else { 0.0 };
            s += g * g;
        }
    }
    let e = s.sqrt() * UP + 2e-6;
    if e > 0.1 {
        return None;
    }
    let [x, y, z] = [row(0), row(1), row(2)];
    let det = x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0])
        + x[2] * (y[0] * z[1] - y[1] * z[0]);
    Some((e, det > 0.0))
}

/// Where a walk puts the nodes it stops at: a worker's next cut, or
/// nowhere ([`first_hit`]).
trait CutSink {
    /// Keep `cut`.
    fn push(&mut self, cut: Cut);
}

impl CutSink for Vec<Cut> {
    #[inline(always)]
    fn push(&mut self, cut: Cut) {
        Vec::push(self, cut);
    }
}

/// A walk's cut, kept nowhere.
struct NoCut;

impl CutSink for NoCut {
    #[inline(always)]
    fn push(&mut self, _: Cut) {}
}

/// The tree walk from node `root` for query `q`, depth first: a node
/// printed after the cutoff, or clear of the head by its sphere, its slab
/// or the hull plane facing it, is skipped; a node wholly inside the head
/// is a hit ([`NO_TRIANGLE`]); a leaf's existing triangles are tested on
/// the spot ([`leaf_hit`]). The first hit ends the walk; until then what
/// it stops at goes to `cut`.
// Inlined: `Frontier::first_hit` calls it once for each cut node it walks
// again (74 a query on dome_cut tilted 50°), and a call's set-up of the
// query and the scene was 8 % of the graph's instructions.
#[inline(always)]
fn walk(
    s: &SceneView,
    q: &GpuQuery,
    root: u32,
    stack: &mut [u32; STACK_SIZE],
    cut: &mut impl CutSink,
) -> Option<u32> {
    stack[0] = root;
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let i = stack[sp];
        let node = s.nodes[i as usize];
        if node.min_stamp >= q.cutoff {
            cut.push(Cut {
                node: i,
                clear: AFTER_CUTOFF,
                reach: 0.0,
            });
            continue;
        }
        let c = to_head(q, node.center);
        let margin = sphere_margin(q, c, node.radius);
        let (inside, clear) = sphere_clearance(s.head, s.grid, c, node.radius);
        if inside {
            keep_unwalked(cut, i, &stack[..sp]);
            return Some(NO_TRIANGLE);
        }
        // Clear by its sphere, else by its slab, else by the hull's plane:
        // the cut keeps how far.
        let clear = if clear - s.head.grid_slack > margin {
            clear
        } else {
            slab_gap_of(s.support, q, &node, &s.slabs[i as usize])
        };
        let clear = if clear - s.head.grid_slack > margin {
            clear
        } else {
            node_hull_gap_of(s.head, s.grid, q, &node, &s.slabs[i as usize], c)
        };
        if clear - s.head.grid_slack > margin {
            cut.push(Cut {
                node: i,
                clear,
                reach: length(c) + node.radius,
            });
            continue;
        }
        match node.leaf_range() {
            Some((first, count)) => {
                if let Some(t) = leaf_hit(s, q, first, count) {
                    keep_unwalked(cut, i, &stack[..sp]);
                    return Some(t);
                }
                cut.push(again(i));
            }
            None => {
                stack[sp] = node.packed;
                stack[sp + 1] = node.packed + 1;
                sp += 2;
            }
        }
    }
    None
}

/// A walk that hit at node `at`, with `stack` still to walk: both go to
/// `cut` to be walked again, so that every triangle still lies below
/// one of its nodes.
#[inline(always)]
fn keep_unwalked(cut: &mut impl CutSink, at: u32, stack: &[u32]) {
    cut.push(again(at));
    for &n in stack {
        cut.push(again(n));
    }
}

/// The grid's verdict on the sphere `(c, r)` (head frame), as
/// [`super::common::classify`] reads it: whether it lies wholly inside the
/// head, and a lower bound on its distance from the head when it lies
/// outside (`v − |c − centre| − r`, or the head box's distance beyond
/// the grids; negative when nothing is known).
// Inlined as the walk is: once a node visit, 1.7 % of the graph's
// instructions as a call.
#[inline(always)]
fn sphere_clearance(h: &GpuHeadParams, grid: &[f32], c: V3, r: f32) -> (bool, f32) {
    let g = grid_sample(h, grid, c);
    let (v, Some((ijk, origin, cell))) = (g.v, g.cell) else {
        return (false, g.v - r);
    };
    let d = [
        c[0] - (origin[0] + (ijk[0] as f32 + 0.5) * cell),
        c[1] - (origin[1] + (ijk[1] as f32 + 0.5) * cell),
        c[2] - (origin[2] + (ijk[2] as f32 + 0.5) * cell),
    ];
    let bound = v.abs() - length(d) - r;
    if v < 0.0 {
        (bound - h.grid_slack > 0.0, -1.0)
    } else {
        (false, bound)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::cpu::expand::pose_query;
    use crate::collide::cpu::{exact::pair_hits, traverse};
    use crate::collide::gpu::wire::GpuMotion;

    use crate::default_job::scene;

    /// Every verdict from a cut is the walk from the root's, and the
    /// kernels' (their mirrors: the walk's hit, or a pair it hands over
    /// hitting by the exact tests), over the waypoints in print order
    /// (small steps; each waypoint asked three times, its tip moved a
    /// little, as a move's samples share a cutoff) at margins and slopes
    /// that change from query to query, and through jumps: back and forth
    /// in the print (the cutoff falls as well as rises), to far poses, and
    /// to the whole part printed.
    /// And the cut is what saves the work: most queries carry nodes over,
    /// among them nodes printed after the cutoff, and a query after a hit
    /// walks from the cut the hit left.
    #[test]
    fn walks_from_the_last_cut_give_the_roots_verdicts() {
        let scene = scene();
        let view = SceneView::new(&scene);
        let mut uniform = crate::geometry::xorshift(0x5eed_1234_abcd_0001);
        let mut next = || uniform() as f32;
        let mut f = Frontier::default();
        let (mut hits, mut asked) = (0, 0);
        let n = scene.waypoint_queries.len();
        let mut g = 0usize;
        for step in 0..6000 {
            g = if step % 500 == 499 {
                (next() * n as f32) as usize % n
            } else if step % 3 == 0 {
                (g + 1) % n
            } else {
                g
            };
            let base = scene.waypoint_queries[g];
            let mut q = base.to_gpu();
            q.rows[0][3] += 0.15 * (step % 3) as f32;
            if step % 50 == 49 {
                // Everything printed: the material the last cut left out
                // as printed later is there now.
                q.cutoff = u32::MAX;
            }
            q.margin = [0.0, 0.05, 0.3, 1.0][step % 4];
            q.slope = if step % 3 == 0 { 0.02 * next() } else { 0.0 };
            if step % 7 == 0 {
                // A tilted variant: the head turned up to ~30° about x.
                let a = 0.5 * next();
                let (c, s) = (a.cos(), a.sin());
                for row in &mut q.rows {
                    let (y, z) = (row[1], row[2]);
                    row[1] = c * y - s * z;
                    row[2] = s * y + c * z;
                }
            }
            let plain = first_hit(&view, &q).is_some();
            let w = traverse::walk(&view, &q);
            let kernels = w.hit || w.candidates.iter().any(|&t| pair_hits(&view, &q, t));
            assert_eq!(plain, kernels, "query {step}: the kernels' verdict");
            assert_eq!(f.first_hit(&view, &q).is_some(), plain, "query {step}");
            hits += plain as usize;
            asked += 1;
        }
        assert!(hits > 100 && hits < asked - 100, "{hits} hits of {asked}");
        assert!(f.carried > 5_000, "{} cut nodes carried", f.carried);
        assert!(
            f.carried_after_cutoff > 1_000,
            "{} cut nodes carried as printed after the cutoff",
            f.carried_after_cutoff
        );
        assert!(f.after_hit > 100, "{} walks from a hit's cut", f.after_hit);
    }

    /// A query after a hit, walked from the cut the hit left, gives the
    /// root's verdict, next to the hit and far from it: the cut's
    /// clearances shrink by the motion since, and what the hit left
    /// unwalked is walked again. Each trial asks a free pose (a cut to
    /// start from), a colliding one (the tip pushed into the material
    /// below) next to it or far, then another pose, colliding or not:
    /// the hit's turned, a later waypoint's, or anywhere.
    #[test]
    fn walks_from_a_hits_cut_give_the_roots_verdicts() {
        let scene = scene();
        let view = SceneView::new(&scene);
        let mut uniform = crate::geometry::xorshift(0x5eed_1234_abcd_0002);
        let mut next = || uniform() as f32;
        let n = scene.waypoint_queries.len();
        let at = |g: usize, sink: f32| {
            let mut q = scene.waypoint_queries[g % n].to_gpu();
            q.rows[2][3] -= sink;
            q.margin = 0.05;
            q
        };
        let (mut trials, mut hits, mut from_cut) = (0, 0, 0);
        for trial in 0..3000 {
            // The free pose at one waypoint, the hit at another, often
            // far: what the hit's walk left unlooked at is known only as
            // far as the motion from the free pose allows.
            let g = (next() * n as f32) as usize % n;
            let far = if trial % 2 == 0 {
                1
            } else {
                (next() * n as f32) as usize
            };
            let (free, hit) = (at(g, 0.0), at(g + far, 1.0));
            let g = g + far;
            let after = match trial % 3 {
                // The hit's tip, the head turned (a column's variant).
                0 => {
                    let mut q = hit;
                    let (c, s) = (0.3f32.cos(), 0.3f32.sin());
                    for j in 0..3 {
                        let (y, z) = (q.rows[1][j], q.rows[2][j]);
                        q.rows[1][j] = c * y - s * z;
                        q.rows[2][j] = s * y + c * z;
                    }
                    q
                }
                // A waypoint up to 200 further on, sunk less or more.
                1 => at(g + 1 + (200.0 * next()) as usize, 1.5 * next()),
                // Anywhere.
                _ => at((next() * n as f32) as usize, next()),
            };
            if first_hit(&view, &free).is_some() || first_hit(&view, &hit).is_none() {
                continue;
            }
            let mut f = Frontier::default();
            assert!(f.first_hit(&view, &free).is_none());
            assert!(f.first_hit(&view, &hit).is_some());
            let plain = first_hit(&view, &after).is_some();
            assert_eq!(f.first_hit(&view, &after).is_some(), plain, "trial {trial}");
            trials += 1;
            hits += plain as usize;
            from_cut += f.after_hit;
        }
        assert!(trials > 100 && hits > 30, "{hits} hits in {trials} trials");
        assert!(
            4 * from_cut > trials,
            "{from_cut} of {trials} from the hit's cut"
        );
    }

    /// A cut node a hit left unlooked at keeps what it knew, less the
    /// motion since: its clearance shrinks by the motion's bound at its
    /// reach, which grows by as much; one the motion exhausts is walked
    /// again; one printed after the cutoff stays so while the cutoff
    /// does not rise.
    #[test]
    fn a_hits_unwalked_nodes_keep_what_they_knew_less_the_motion() {
        let mut q = GpuQuery {
            cutoff: 10,
            ..Default::default()
        };
        let known = Cut {
            node: 7,
            clear: 2.0,
            reach: 10.0,
        };
        // 0.5 mm moved and 0.125 turned: 1.75 mm at a reach of 10.
        let seen = known.seen_from(&q, 10, 0.5, 0.125);
        assert_eq!((seen.node, seen.clear, seen.reach), (7, 0.25, 11.75));
        let seen = known.seen_from(&q, 10, 0.5, 0.25);
        assert_eq!((seen.node, seen.clear), (7, -1.0));
        assert_eq!(again(7).seen_from(&q, 10, 0.0, 0.0).clear, -1.0);
        let late = Cut {
            node: 3,
            clear: AFTER_CUTOFF,
            reach: 0.0,
        };
        assert_eq!(late.seen_from(&q, 10, 5.0, 1.0).clear, AFTER_CUTOFF);
        q.cutoff = 11;
        assert_eq!(late.seen_from(&q, 10, 0.0, 0.0).clear, -1.0);
    }

    /// The 3×3 part of a frame, as f64.
    fn frame_of(m: &[[f32; 4]; 3]) -> [[f64; 3]; 3] {
        std::array::from_fn(|i| std::array::from_fn(|j| m[i][j] as f64))
    }

    /// `‖A − B‖₂` of two frames' 3×3 parts, in f64: the square root of
    /// the largest eigenvalue of `DᵀD` (`D = A − B`), by power iteration
    /// from each axis (a 3×3 converges long before 200 steps).
    fn spectral_norm(a: &[[f32; 4]; 3], b: &[[f32; 4]; 3]) -> f64 {
        let (a, b) = (frame_of(a), frame_of(b));
        let d: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] - b[i][j]));
        let apply = |v: [f64; 3]| -> [f64; 3] {
            let w: [f64; 3] = std::array::from_fn(|i| (0..3).map(|k| d[i][k] * v[k]).sum());
            std::array::from_fn(|j| (0..3).map(|i| d[i][j] * w[i]).sum())
        };
        let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        (0..3)
            .map(|axis| {
                let mut v = [0.0; 3];
                v[axis] = 1.0;
                let mut lambda: f64 = 0.0;
                for _ in 0..200 {
                    let w = apply(v);
                    let n = norm(w);
                    if n == 0.0 {
                        break;
                    }
                    lambda = n / norm(v);
                    v = w.map(|x| x / n);
                }
                lambda.sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// `‖A − B‖_F` in f64.
    fn frobenius(a: &[[f32; 4]; 3], b: &[[f32; 4]; 3]) -> f64 {
        let (a, b) = (frame_of(a), frame_of(b));
        (0..9)
            .map(|k| (a[k / 3][k % 3] - b[k / 3][k % 3]).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// The frame of the rotation by `angle` about the unit `axis`
    /// (Rodrigues, f64, rounded to f32 as a query holds it).
    fn rotation(axis: [f64; 3], angle: f64) -> [[f32; 4]; 3] {
        let (s, c) = angle.sin_cos();
        let [x, y, z] = axis;
        let m = [
            [
                c + x * x * (1.0 - c),
                x * y * (1.0 - c) - z * s,
                x * z * (1.0 - c) + y * s,
            ],
            [
                y * x * (1.0 - c) + z * s,
                c + y * y * (1.0 - c),
                y * z * (1.0 - c) - x * s,
            ],
            [
                z * x * (1.0 - c) - y * s,
                z * y * (1.0 - c) + x * s,
                c + z * z * (1.0 - c),
            ],
        ];
        std::array::from_fn(|i| [m[i][0] as f32, m[i][1] as f32, m[i][2] as f32, 0.0])
    }

    /// The frame `m` with its columns scaled by `s` (`M diag(s)`).
    fn scaled(m: [[f32; 4]; 3], s: [f32; 3]) -> [[f32; 4]; 3] {
        m.map(|r| [r[0] * s[0], r[1] * s[1], r[2] * s[2], r[3]])
    }

    /// Between two rotations the turn bound holds (at least the spectral
    /// norm of their difference) and is the rotations' own: the
    /// Frobenius norm over √2, not the Frobenius norm. Frames built as
    /// the queries' are — a rotation in f64 rounded to f32, and the
    /// products of f32 sines and cosines the motion kernel poses
    /// samples with — at turns from a sample's 10⁻⁴ rad to a half turn.
    #[test]
    fn the_turn_bound_holds_and_is_the_rotations_own() {
        let mut uniform = crate::geometry::xorshift(0x7e11_0b0d_2024_0001);
        let motion_frame = |t: f32, c: f32| {
            let m = GpuMotion {
                rotary: 2,
                ..Default::default()
            };
            pose_query(&m, [0.0; 3], t, c, 0, 0.0).rows
        };
        let mut pairs = Vec::new();
        for k in 0..2000 {
            let mut axis = [0.0; 3].map(|_: f64| uniform() - 0.5);
            let n = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
            axis = axis.map(|x| x / n);
            let turn = 10f64.powf(-4.0 + 4.5 * uniform()).min(std::f64::consts::PI);
            let a = rotation(axis, 6.3 * uniform());
            let b_axis = if k % 2 == 0 {
                axis
            } else {
                [axis[1], axis[2], axis[0]]
            };
            let a_angle = 6.3 * uniform();
            pairs.push((a, rotation(b_axis, a_angle + turn)));
            if k % 2 == 0 {
                let (t, c) = (uniform() as f32 * 1.5, uniform() as f32 * 6.3);
                let d = turn as f32;
                pairs.push((motion_frame(t, c), motion_frame(t + 0.3 * d, c + d)));
            }
        }
        for (a, b) in &pairs {
            let (_, turned) = motion(a, b);
            let exact = spectral_norm(a, b);
            assert!(turned as f64 >= exact, "{turned} < {exact}: {a:?} {b:?}");
            let own = frobenius(a, b) / 2f64.sqrt();
            assert!(
                turned as f64 <= own * 1.0001 + 2e-5,
                "{turned} against {own}"
            );
        }
    }

    /// Frames that are not rotations keep a bound that holds: one
    /// stretched a little along an axis (its defect counts), one of the
    /// other handedness (a mirror: `I − Q` then has the singular value
    /// 2), one far from orthogonal (the Frobenius norm). Each would
    /// break the rotations' bound.
    #[test]
    fn frames_that_are_not_rotations_keep_a_bound_that_holds() {
        let r = rotation([0.6, 0.0, 0.8], 0.7);
        let cases = [
            (r, scaled(r, [1.01, 1.0, 1.0])),
            (r, scaled(r, [1.0, 1.0, -1.0])),
            (r, scaled(r, [1.5, 1.0, 1.0])),
        ];
        for (a, b) in &cases {
            let (_, turned) = motion(a, b);
            let exact = spectral_norm(a, b);
            assert!(turned as f64 >= exact, "{turned} < {exact}: {b:?}");
            assert!(
                frobenius(a, b) / 2f64.sqrt() < exact,
                "the rotations' bound would break"
            );
        }
    }
}
