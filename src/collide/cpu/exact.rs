//! CPU mirror of `shaders/collide_exact.wgsl`: the exact tests of one
//! (query, triangle) pair the walk ([`super::traverse`]) could not settle
//! — Möller against the head and, with a margin, the distance tests, then
//! containment of one vertex ([`super::common::tri_hits_exact`]). The kernel runs
//! one invocation per pair and ORs the answer into the query's verdict;
//! this is that answer.

use super::common::{head_tri, tri_hits_exact, SceneView};
use crate::scene::GpuQuery;

/// Does part triangle `t` hit the head at query `q`, by the exact tests?
/// (The kernel reads it as an undecided pair; the stamp was checked by
/// the walk.)
///
/// Twin: `main` (`collide_exact.wgsl`) for one candidate.
pub fn pair_hits(s: &SceneView, q: &GpuQuery, t: u32) -> bool {
    let h = head_tri(s, q, &s.tris[t as usize]);
    tri_hits_exact(s, h.a, h.b, h.c, h.margin)
}
