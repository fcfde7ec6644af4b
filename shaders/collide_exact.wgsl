// Pass 2, one invocation per candidate (query, triangle): the exact tests
// (Möller against the head, then containment, then the distance when the
// query has a safety margin) for triangles the grid could not settle.
// Mirrored by src/collide/cpu/exact.rs.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if k >= min(atomicLoad(&control.count), params.capacity) {
        return;
    }
    let pair = candidates[k];
    if (atomicLoad(&results[pair.x]) & RESULT_HIT) != 0u {
        return; // Already colliding.
    }
    let q = queries[pair.x];
    let h = head_tri(q, part_tri(pair.y));
    if tri_hits_exact(h.a, h.b, h.c, h.margin) {
        atomicOr(&results[pair.x], RESULT_HIT);
    }
}
