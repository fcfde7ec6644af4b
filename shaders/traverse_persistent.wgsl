// collide_traverse's entry point on adapters with subgroups: persistent
// lanes. A subgroup's lanes run in lock-step, so one invocation a query
// keeps every lane until the group's longest walk ends, which is often
// nearly twice an average lane's. Here an invocation whose walk has
// ended takes the next query of the batch (`control.next`) and walks on.
// Taking one costs reads (the query, the root), so a subgroup walks until
// a quarter of its lanes wait, then they all take their next query
// together (Aila and Laine's persistent threads with dynamic fetch):
// fewer instructions than one query an invocation (traverse_lane.wgsl),
// and fewer than refilling at a half of the lanes or at one lane.
//
// Every invocation takes its first query whatever happens, and a batch
// dispatches one invocation per query, so every query is walked. Later
// takes stop after LANE_QUERIES queries, or once the lane's walks have
// made LANE_STEPS loop iterations (a node, or a leaf and its triangles):
// lavapipe ends an invocation's loops after 65,535 iterations in all (its
// loop limiter), and lanes that take queries without end can reach that
// on long walks (a tilted head over a printed part) and leave queries
// unwalked. A subgroup's lanes share that count (they run as one SIMD
// loop), and a lane's steps bound the group's iterations only while it
// walks, so LANE_STEPS is an eighth of the limit: 16 long walks take a
// few thousand.

const NO_QUERY: u32 = 0xffffffffu;
const LANE_QUERIES: u32 = 16u;
const LANE_STEPS: u32 = 8192u;
// A subgroup refills when 1 / REFILL of its lanes wait.
const REFILL: u32 = 4u;

// How many of the subgroup's lanes `yes` holds for.
fn lanes_where(yes: bool) -> u32 {
    let b = subgroupBallot(yes);
    return countOneBits(b.x) + countOneBits(b.y) + countOneBits(b.z) + countOneBits(b.w);
}

@compute @workgroup_size(64)
fn main(@builtin(subgroup_size) lanes: u32) {
    var w: Walk;
    w.qi = NO_QUERY;
    // Whether this lane may take more queries.
    var more = true;
    var taken = 0u;
    var steps = 0u;
    let refill_at = max(1u, lanes / REFILL);
    loop {
        // Lanes without a query take the next one that needs a walk.
        if w.qi == NO_QUERY && more {
            loop {
                if taken > 0u && (taken >= LANE_QUERIES || steps >= LANE_STEPS) {
                    more = false;
                    break;
                }
                taken += 1u;
                let qi = atomicAdd(&control.next, 1u);
                if qi >= params.query_count {
                    more = false;
                    break;
                }
                let start = walk_needed(qi);
                if start.walk {
                    walk_begin(&w, qi, start.handed);
                    break;
                }
            }
        }
        if subgroupAll(w.qi == NO_QUERY) {
            break;
        }
        // Walk until enough lanes wait (or none walks).
        loop {
            let walking = w.qi != NO_QUERY && walk_on(&w);
            let waiting = !walking && (w.qi != NO_QUERY || more);
            if lanes_where(waiting) >= refill_at || lanes_where(walking) == 0u {
                break;
            }
            if walking {
                steps += walk_step(&w);
            }
        }
        // Lanes whose walk ended write its result.
        if w.qi != NO_QUERY && !walk_on(&w) {
            walk_end(&w);
            w.qi = NO_QUERY;
        }
    }
}
