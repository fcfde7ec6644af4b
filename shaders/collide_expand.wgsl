// Before a batch of moves, one invocation per move: pose its samples as
// the machine interpolates the move and write them into the batch's query
// slots (collide_traverse and collide_exact then decide them like any
// query). Mirrored by src/collide/cpu/expand.rs.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let mi = gid.x;
    if mi >= motion.move_count {
        return;
    }
    let m = moves[mi];
    for (var k = 1u; k <= m.count; k++) {
        sample_queries[m.first + k - 1u] = sample_query(m, k);
    }
}
