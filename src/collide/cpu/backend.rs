//! The `cpu` backend: a worker per rayon thread answers each query by the
//! tree walk of [`super::frontier`], from the cut its last query stopped
//! at, after trying the triangles that decided its recent hits
//! ([`witness_hits`]); no allocation per query. Nothing here has a WGSL
//! twin, and nothing here changes a verdict: a witness only answers yes
//! where the walk would reach that triangle and find the same.

use super::common::SceneView;
use super::frontier::{tri_hits, Frontier, NO_TRIANGLE};
use crate::collide::{check_finite, Backend, CollideError, Query};
use crate::scene::{GpuQuery, Scene};
use rayon::prelude::*;

/// The `cpu` backend.
pub struct CpuBackend<'a> {
    view: SceneView<'a>,
}

impl<'a> CpuBackend<'a> {
    /// A backend over `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        assert!(
            !scene.bvh_released(),
            "a backend on a scene whose BVH was released"
        );
        CpuBackend {
            view: SceneView::new(scene),
        }
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> &'static str {
        "cpu"
    }

    /// Each worker first tries the triangles that decided its recent
    /// hits when its last query hit (`Worker`, [`witness_hits`]): a
    /// colliding query otherwise walks the tree until it meets one, and
    /// colliding poses cost more to walk than free ones.
    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        check_finite(queries)?;
        Ok(queries
            .par_iter()
            .with_min_len(64)
            .map_init(Worker::default, |w, q| w.answer(&self.view, &q.to_gpu()))
            .collect())
    }
}

/// Triangles that decided a worker's recent hits, tried before a walk
/// that follows a hit.
const WITNESSES: usize = 8;

/// What a rayon worker keeps between its queries.
struct Worker {
    /// The triangles that decided its recent hits, most recent first
    /// ([`NO_TRIANGLE`]: none yet). A colliding waypoint's variants, the
    /// directions of a shell that all collide, a move's failing samples:
    /// the planner asks neighbouring poses in a row, and they mostly hit
    /// one of the few triangles the last hits did. Eight cost nothing
    /// measurable where nothing collides and pay most where whole columns
    /// do (fewer paid less).
    witnesses: [u32; WITNESSES],
    /// The cut of the tree its last walk stopped at ([`Frontier`]).
    cut: Frontier,
    /// Whether its last query hit.
    last_hit: bool,
}

impl Default for Worker {
    fn default() -> Self {
        Worker {
            witnesses: [NO_TRIANGLE; WITNESSES],
            cut: Default::default(),
            last_hit: false,
        }
    }
}

impl Worker {
    /// Whether `q` hits: after a hit, trying the witnesses first (a
    /// triangle that decides a hit moves to the front), then walking from
    /// the last cut. Hits come in runs, and a query after a free one is
    /// seldom decided by a witness: tried after every query, they cost
    /// about 2 % more instructions in each stage than they save (the
    /// columns', the graph's and the input's queries of dome_cut tilted
    /// 50°).
    fn answer(&mut self, s: &SceneView, q: &GpuQuery) -> bool {
        let hit = self.decide(s, q);
        self.last_hit = hit;
        hit
    }

    /// [`Worker::answer`]'s verdict.
    fn decide(&mut self, s: &SceneView, q: &GpuQuery) -> bool {
        let w = &mut self.witnesses;
        if self.last_hit {
            if let Some(k) = (0..WITNESSES).find(|&k| witness_hits(s, q, w[k])) {
                w[..=k].rotate_right(1);
                return true;
            }
        }
        let hit = self.cut.first_hit(s, q);
        if let Some(t) = hit.filter(|&t| t != NO_TRIANGLE) {
            w.rotate_right(1);
            w[0] = t;
        }
        hit.is_some()
    }
}

/// Does triangle `t` (an earlier query's
/// [`first_hit`](super::frontier::first_hit)) exist at `q`'s
/// cutoff and hit the head there? A yes is the query's answer: the walk
/// would reach that triangle (only nodes clear of the head are skipped)
/// and find the same.
#[inline(always)]
pub fn witness_hits(s: &SceneView, q: &GpuQuery, t: u32) -> bool {
    let Some(tri) = s.tris.get(t as usize) else {
        return false;
    };
    tri.stamp < q.cutoff && tri_hits(s, q, tri)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A worker tries its witnesses only after a hit: a query that a
    /// triangle of its last hit decides is answered without a walk right
    /// after that hit, and walked after a free query. The verdicts are
    /// the walk's either way.
    #[test]
    fn witnesses_are_tried_only_after_a_hit() {
        use crate::collide::cpu::frontier::first_hit;
        let scene = crate::default_job::scene();
        let view = SceneView::new(&scene);
        let n = scene.waypoint_queries.len();
        let at = |g: usize, sink: f32| {
            let mut q = scene.waypoint_queries[g].to_gpu();
            q.rows[2][3] -= sink;
            q.margin = 0.05;
            q
        };
        let mut checked = 0;
        for g in (0..n).step_by(97) {
            let (free, hit) = (at(g, 0.0), at(g, 1.0));
            let by_triangle = matches!(first_hit(&view, &hit), Some(t) if t != NO_TRIANGLE);
            if first_hit(&view, &free).is_some() || !by_triangle {
                continue;
            }
            let mut w = Worker::default();
            assert!(w.answer(&view, &hit));
            let walked = w.cut.walks();
            assert!(w.answer(&view, &hit), "waypoint {g}");
            assert_eq!(w.cut.walks(), walked, "waypoint {g}: a witness decides");
            assert!(!w.answer(&view, &free), "waypoint {g}");
            assert!(w.answer(&view, &hit), "waypoint {g}");
            assert_eq!(w.cut.walks(), walked + 2, "waypoint {g}: walked");
            checked += 1;
        }
        assert!(checked > 5, "{checked} waypoints");
    }

    /// A scene whose BVH was released (`plan` does so before its report)
    /// is refused, not walked as if it held no part.
    #[test]
    #[should_panic(expected = "released")]
    fn a_scene_without_its_bvh_is_refused() {
        let mut scene = crate::default_job::scene();
        assert!(!scene.bvh_released());
        scene.release_bvh();
        assert!(scene.bvh_released() && scene.part_tris.is_empty());
        CpuBackend::new(&scene);
    }
}
