// After a batch of moves, one invocation per move: the move collides when
// any of its samples does (one word per move comes back, not one per
// sample). Mirrored by src/collide/cpu/reduce.rs.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let mi = gid.x;
    if mi >= motion.move_count {
        return;
    }
    let m = moves[mi];
    var hit = 0u;
    for (var k = 0u; k < m.count; k++) {
        hit |= sample_results[m.first + k] & RESULT_HIT_BIT;
    }
    move_results[mi] = hit;
}
