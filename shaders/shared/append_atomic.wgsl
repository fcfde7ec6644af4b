// How collide_traverse reserves its next slot of the candidate list, on
// an adapter without subgroup operations: one atomic per pair. Its twin
// append_subgroup.wgsl reserves the slots of a subgroup's lanes with one.
fn append_slot() -> u32 {
    return atomicAdd(&control.count, 1u);
}
