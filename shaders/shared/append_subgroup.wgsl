// How collide_traverse reserves its next slot of the candidate list, on an
// adapter with subgroup operations: the lanes appending at this point
// count themselves, the first of them reserves that many slots with one
// atomic, and each takes the slot of its rank. A query's pairs still get
// ever larger slots, in its walk order (what the resumed passes rely on).
// On lavapipe an atomic is a loop over the SIMD lanes; on a GPU one
// atomic a subgroup instead of one a lane spares the counter's traffic.
fn append_slot() -> u32 {
    let rank = subgroupExclusiveAdd(1u);
    let count = subgroupAdd(1u);
    var first = 0u;
    if rank == 0u {
        first = atomicAdd(&control.count, count);
    }
    return subgroupBroadcastFirst(first) + rank;
}
