// Pass 1 of a batch: for each query, walk the part BVH, settle
// what the distance grid can (nodes and triangles wholly outside or
// inside the head) and append the undecided (query, triangle) pairs to the
// candidate list for collide_exact. Splitting the work this way keeps each
// kernel's loops un-nested, which lavapipe needs to compile them correctly,
// and spreads the exact tests evenly over the GPU's threads.
//
// A query hands over at most params.per_query pairs a pass and stops
// walking when it meets one more: a colliding query's first pairs (the
// deepest nodes are walked first) mostly settle it, and the rest of its
// walk, often the longer part, is never made. The list is shared by the
// batch and may fill; the counter only grows, so once one append of a
// query fails every later one would, and the walk stops there too. Either
// way the pairs a query handed over are the first ones of its walk order.
// It records how many (the result word, RESULT_STORED_SHIFT) and that some
// are missing (RESULT_INCOMPLETE). A resumed pass (params.resume) walks
// again only the queries still incomplete and undecided, and appends the
// pairs after those: no pair is tested twice and no batch is redone.
// Children are tested before they are pushed, the one reaching deeper
// into the head on top: a colliding query meets a node or triangle
// wholly inside the head sooner, which decides it without exact tests
// (fewer than walking the nearer child to the tip first). Mirrored by
// src/collide/cpu/traverse.rs.
//
// This file is one query's walk, a step at a time (`Walk`); the entry
// point that hands queries to invocations is traverse_lane.wgsl (one
// query an invocation) or traverse_persistent.wgsl (an invocation takes
// the next query when its walk ends; adapters with subgroups).

// A node as the walk sees it: state 1 settled clear (or printed later),
// -1 wholly inside the head (the query collides), 0 undecided; `depth` is
// the head grid's signed distance at its centre less its radius (which
// undecided child goes first: the one reaching deeper into the head).
struct NodeTest {
    state: i32,
    depth: f32,
}

fn test_node(q: Query, i: u32) -> NodeTest {
    let node = part_node(i);
    if node.min_stamp >= q.cutoff {
        return NodeTest(1, 0.0);
    }
    let c = to_head(q, node.center);
    let margin = sphere_margin(q, c, node.radius);
    let g = grid_sample(c);
    let cls = classify_sample(g, c, node.radius, margin);
    if cls != 0 {
        return NodeTest(cls, 0.0);
    }
    if slab_clear(q, node, margin) || node_hull_clear(q, node, c, margin) {
        return NodeTest(1, 0.0);
    }
    return NodeTest(0, g.v - node.radius);
}

// One query's walk: the query, its stack of undecided nodes, whether it
// hit, whether its share of pairs is handed over (`full`), the undecided
// pairs met so far in walk order (`met`; those below `handed` were tested
// in an earlier pass) and how many it has handed over (`stored`).
struct Walk {
    qi: u32,
    q: Query,
    stack: array<u32, STACK_SIZE>,
    sp: u32,
    hit: bool,
    full: bool,
    met: u32,
    stored: u32,
    handed: u32,
}

// The query whose result word (`results[qi]`) needs a walk in this pass:
// every one in a batch's first pass; in a resumed pass, only those still
// incomplete and undecided, with the pairs they handed over before.
struct Start {
    walk: bool,
    handed: u32,
}

fn walk_needed(qi: u32) -> Start {
    if params.resume == 0u {
        return Start(true, 0u);
    }
    let word = atomicLoad(&results[qi]);
    if (word & RESULT_INCOMPLETE) == 0u || (word & RESULT_HIT) != 0u {
        return Start(false, 0u);
    }
    return Start(true, word >> RESULT_STORED_SHIFT);
}

// Start walking query qi: the root tested (nodes are tested before they
// are pushed, so the stack holds undecided nodes only).
fn walk_begin(w: ptr<function, Walk>, qi: u32, handed: u32) {
    (*w).qi = qi;
    (*w).q = queries[qi];
    let root = test_node((*w).q, 0u);
    (*w).hit = root.state < 0;
    (*w).sp = 0u;
    if root.state == 0 {
        (*w).stack[0] = 0u;
        (*w).sp = 1u;
    }
    (*w).full = false;
    (*w).met = 0u;
    (*w).handed = handed;
    (*w).stored = handed;
}

fn walk_on(w: ptr<function, Walk>) -> bool {
    return (*w).sp > 0u && !(*w).hit && !(*w).full;
}

// One node off the stack: a leaf's triangles classified (undecided ones
// handed over, up to the query's share), or an inner node's two children
// tested and the undecided pushed, the deeper on top. Returns the loop
// iterations it made (traverse_persistent.wgsl counts them).
fn walk_step(w: ptr<function, Walk>) -> u32 {
    (*w).sp -= 1u;
    let node = part_node((*w).stack[(*w).sp]);
    var iterations = 1u;
    if is_leaf(node.packed) {
        let first = leaf_first(node.packed);
        let end = first + leaf_count(node.packed);
        iterations += end - first;
        for (var t = first; t < end; t++) {
            let tri = part_tri(t);
            if tri.stamp < (*w).q.cutoff {
                let h = head_tri((*w).q, tri);
                if h.cls < 0 {
                    (*w).hit = true;
                } else if h.cls == 0 {
                    if (*w).met >= (*w).handed && !(*w).full {
                        if (*w).stored - (*w).handed >= params.per_query {
                            (*w).full = true;
                        } else {
                            let k = append_slot();
                            if k < params.capacity {
                                candidates[k] = vec2<u32>((*w).qi, t);
                                (*w).stored += 1u;
                            } else {
                                (*w).full = true;
                            }
                        }
                    }
                    (*w).met += 1u;
                }
            }
        }
    } else {
        let a = node.packed;
        let ta = test_node((*w).q, a);
        let tb = test_node((*w).q, a + 1u);
        let sp = (*w).sp;
        if ta.state < 0 || tb.state < 0 {
            (*w).hit = true;
        } else if ta.state == 0 && tb.state == 0 {
            let a_first = ta.depth <= tb.depth;
            (*w).stack[sp] = select(a, a + 1u, a_first);
            (*w).stack[sp + 1u] = select(a + 1u, a, a_first);
            (*w).sp = sp + 2u;
        } else if ta.state == 0 {
            (*w).stack[sp] = a;
            (*w).sp = sp + 1u;
        } else if tb.state == 0 {
            (*w).stack[sp] = a + 1u;
            (*w).sp = sp + 1u;
        }
    }
    return iterations;
}

// The query's result word: hit, or how many pairs it has handed over and
// whether some are left.
fn walk_end(w: ptr<function, Walk>) {
    if (*w).hit {
        atomicStore(&results[(*w).qi], RESULT_HIT);
    } else {
        let incomplete = select(0u, RESULT_INCOMPLETE, (*w).full);
        atomicStore(&results[(*w).qi], ((*w).stored << RESULT_STORED_SHIFT) | incomplete);
    }
}
