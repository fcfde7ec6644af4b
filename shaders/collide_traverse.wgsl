// Pass 1 of a batch, one invocation per query: walk the part BVH, settle
// what the distance grid can (nodes and triangles wholly outside or
// inside the head) and append the undecided (query, triangle) pairs to the
// candidate list for collide_exact. Splitting the work this way keeps each
// kernel's loops un-nested, which lavapipe needs to compile them correctly,
// and spreads the exact tests evenly over the GPU's threads.
//
// A query hands over at most params.per_query pairs a pass and stops
// walking when it meets one more: a colliding query's first pairs (the
// deepest nodes are walked first) mostly settle it, and the rest of its
// walk is never made (walking on to its end made the tilted
// simple_curve's gpu plan 1.3 times as long). The list is shared by the
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
// (on the tilted simple_curve plan 2.5 M exact tests became 1.6 M and
// the plan took 0.8 of the time it took walking the nearer child to the
// tip first). Mirrored by src/collide/cpu/traverse.rs.

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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let qi = gid.x;
    if qi >= params.query_count {
        return;
    }
    var handed = 0u;
    if params.resume != 0u {
        let word = atomicLoad(&results[qi]);
        if (word & RESULT_INCOMPLETE) == 0u || (word & RESULT_HIT) != 0u {
            return;
        }
        handed = word >> RESULT_STORED_SHIFT;
    }
    let q = queries[qi];
    var stack: array<u32, STACK_SIZE>;
    var sp = 0u;
    // Nodes are tested before they are pushed: the stack holds undecided
    // nodes only, the deeper of two children on top.
    let root = test_node(q, 0u);
    var hit = root.state < 0;
    if root.state == 0 {
        stack[0] = 0u;
        sp = 1u;
    }
    // Undecided pairs met so far, in walk order; those below `handed` were
    // tested in an earlier pass.
    var met = 0u;
    var stored = handed;
    var full = false;
    while sp > 0u && !hit && !full {
        sp -= 1u;
        let node = part_node(stack[sp]);
        if is_leaf(node.packed) {
            let first = leaf_first(node.packed);
            let end = first + leaf_count(node.packed);
            for (var t = first; t < end; t++) {
                let tri = part_tri(t);
                if tri.stamp < q.cutoff {
                    let h = head_tri(q, tri);
                    if h.cls < 0 {
                        hit = true;
                    } else if h.cls == 0 {
                        if met >= handed && !full {
                            if stored - handed >= params.per_query {
                                full = true;
                            } else {
                                let k = append_slot();
                                if k < params.capacity {
                                    candidates[k] = vec2<u32>(qi, t);
                                    stored += 1u;
                                } else {
                                    full = true;
                                }
                            }
                        }
                        met += 1u;
                    }
                }
            }
        } else {
            let a = node.packed;
            let ta = test_node(q, a);
            let tb = test_node(q, a + 1u);
            if ta.state < 0 || tb.state < 0 {
                hit = true;
            } else if ta.state == 0 && tb.state == 0 {
                let a_first = ta.depth <= tb.depth;
                stack[sp] = select(a, a + 1u, a_first);
                stack[sp + 1u] = select(a + 1u, a, a_first);
                sp += 2u;
            } else if ta.state == 0 {
                stack[sp] = a;
                sp += 1u;
            } else if tb.state == 0 {
                stack[sp] = a + 1u;
                sp += 1u;
            }
        }
    }
    if hit {
        atomicStore(&results[qi], RESULT_HIT);
    } else {
        atomicStore(&results[qi], (stored << RESULT_STORED_SHIFT) | select(0u, RESULT_INCOMPLETE, full));
    }
}
