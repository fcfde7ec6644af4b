// Between the passes, one invocation: size collide_exact's indirect
// dispatch from the number of candidates collide_traverse appended.

@compute @workgroup_size(1)
fn main() {
    let n = min(atomicLoad(&control.count), params.capacity);
    control.args[0] = (n + WORKGROUP - 1u) / WORKGROUP;
    control.args[1] = 1u;
    control.args[2] = 1u;
}
