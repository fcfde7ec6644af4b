// collide_traverse's entry point on adapters without subgroups: one
// query an invocation, walked to its end.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let qi = gid.x;
    if qi >= params.query_count {
        return;
    }
    let start = walk_needed(qi);
    if !start.walk {
        return;
    }
    var w: Walk;
    walk_begin(&w, qi, start.handed);
    while walk_on(&w) {
        _ = walk_step(&w);
    }
    walk_end(&w);
}
