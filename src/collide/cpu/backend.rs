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
    /// hits (`Worker`, [`witness_hits`]): a colliding query otherwise
    /// walks the tree until it meets one, and colliding poses cost more
    /// to walk than free ones.
    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        check_finite(queries)?;
        Ok(queries
            .par_iter()
            .with_min_len(64)
            .map_init(Worker::default, |w, q| w.answer(&self.view, &q.to_gpu()))
            .collect())
    }
}

/// Triangles that decided a worker's recent hits, tried before a walk.
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
}

impl Default for Worker {
    fn default() -> Self {
        Worker {
            witnesses: [NO_TRIANGLE; WITNESSES],
            cut: Default::default(),
        }
    }
}

impl Worker {
    /// Whether `q` hits, trying the witnesses first (a triangle that
    /// decides a hit moves to the front), then walking from the last cut.
    fn answer(&mut self, s: &SceneView, q: &GpuQuery) -> bool {
        let w = &mut self.witnesses;
        if let Some(k) = (0..WITNESSES).find(|&k| witness_hits(s, q, w[k])) {
            w[..=k].rotate_right(1);
            return true;
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
