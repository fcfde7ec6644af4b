//! An order of a batch's queries in which neighbours walk alike.
//!
//! A GPU runs its invocations in lock-step groups (a subgroup: 32 or 64
//! lanes on hardware, 8 on lavapipe's 256-bit SIMD), and a group's walk
//! lasts as long as its longest lane's. Queries posed alike walk alike: the
//! same orientation puts the head's flanks at the same side of the tip,
//! and nearby tips meet the same part nodes. [`coherent_order`] sorts a
//! batch by the nozzle axis's cell on an octahedral map first, then by the
//! tip's Morton code, so a group's lanes hold neighbouring poses; the
//! backend walks them in that order and returns the verdicts in the
//! caller's.
//!
//! The axis map's cells ([`AXIS_CELLS`]) are as coarse as still groups
//! alike walks: finer maps scatter neighbours, coarser ones mix
//! orientations (BENCHMARKS.md).
//!
//! The gpu backend orders on software adapters only
//! ([`crate::collide::gpu::GpuOptions::coherent`]): a hardware GPU's
//! scheduler hides a divergent lane behind others, so there ordering
//! costs the host more than it saves the device (BENCHMARKS.md, "On a
//! real GPU").

use super::Query;
use rayon::prelude::*;

/// Cells per side of the octahedral map of nozzle axes (16 × 16 cells,
/// about 11° across).
pub const AXIS_CELLS: u32 = 16;

/// Bits per coordinate of the tip's Morton code (over the batch's box).
const MORTON_BITS: u32 = 10;

/// The indices of `queries` in coherent order: by nozzle-axis cell, then
/// by the tip's Morton code, then by index (deterministic).
pub fn coherent_order(queries: &[Query]) -> Vec<u32> {
    let (lo, scale) = tip_frame(queries);
    // Keys and sort on all cores: on one core ordering a large batch
    // costs a fair part of what a hardware GPU takes to walk it. The
    // (key, index) pairs are distinct, so the order is the same however
    // the sort splits its work.
    let mut keyed: Vec<(u64, u32)> = queries
        .par_iter()
        .enumerate()
        .map(|(i, q)| (key(q, lo, scale), i as u32))
        .collect();
    keyed.par_sort_unstable();
    keyed.into_par_iter().map(|(_, i)| i).collect()
}

/// The lower corner of the batch's tips and the scale that maps the
/// longest side of their box onto the Morton code's range.
fn tip_frame(queries: &[Query]) -> ([f32; 3], f32) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for q in queries {
        for k in 0..3 {
            lo[k] = lo[k].min(q.pose.tip[k]);
            hi[k] = hi[k].max(q.pose.tip[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    let top = ((1u32 << MORTON_BITS) - 1) as f32;
    (lo, if extent > 0.0 { top / extent } else { 0.0 })
}

/// A query's sort key: axis cell in the high bits, tip Morton code below.
fn key(q: &Query, lo: [f32; 3], scale: f32) -> u64 {
    let cell = axis_cell(q.pose.cols[2]) as u64;
    let top = (1u32 << MORTON_BITS) - 1;
    let coord = |k: usize| (((q.pose.tip[k] - lo[k]) * scale) as u32).min(top);
    let morton = spread(coord(0)) | spread(coord(1)) << 1 | spread(coord(2)) << 2;
    cell << (3 * MORTON_BITS) | morton
}

/// The cell of unit vector `a` on the octahedral map (`AXIS_CELLS`² cells;
/// the lower hemisphere folded outwards, as `scene::slab::oct_decode`
/// unfolds it).
pub fn axis_cell(a: [f32; 3]) -> u32 {
    let l1 = a[0].abs() + a[1].abs() + a[2].abs();
    if l1 <= 0.0 {
        return 0;
    }
    let (mut u, mut v) = (a[0] / l1, a[1] / l1);
    if a[2] < 0.0 {
        (u, v) = ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum());
    }
    let n = AXIS_CELLS as f32;
    let cell = |x: f32| (((x + 1.0) * 0.5 * n) as u32).min(AXIS_CELLS - 1);
    cell(v) * AXIS_CELLS + cell(u)
}

/// The low `MORTON_BITS` bits of `v`, two zero bits after each.
fn spread(v: u32) -> u64 {
    let mut x = (v & ((1 << MORTON_BITS) - 1)) as u64;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pose::Pose;

    fn query(tip: [f32; 3], axis: [f32; 3]) -> Query {
        Query {
            pose: Pose::from_axis(tip, axis),
            cutoff: 1,
            margin: 0.0,
            slope: 0.0,
        }
    }

    #[test]
    fn spread_puts_two_zero_bits_after_each_bit() {
        for v in [0u32, 1, 2, 3, 5, 0x155, 0x2aa, 0x3ff] {
            let plain: u64 = (0..MORTON_BITS)
                .map(|b| (((v >> b) & 1) as u64) << (3 * b))
                .sum();
            assert_eq!(spread(v), plain, "{v:#x}");
        }
    }

    #[test]
    fn axis_cells_cover_the_map_and_opposite_axes_differ() {
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..64 {
            for j in 0..32 {
                let step = std::f32::consts::PI / 32.0;
                let az = i as f32 * step;
                let el = (j as f32 + 0.5) * step - std::f32::consts::FRAC_PI_2;
                let a = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
                let c = axis_cell(a);
                assert!(c < AXIS_CELLS * AXIS_CELLS);
                assert_ne!(c, axis_cell([-a[0], -a[1], -a[2]]), "{a:?}");
                seen.insert(c);
            }
        }
        assert!(seen.len() > 200, "{} cells", seen.len());
    }

    /// The order is a permutation; each axis cell's queries are contiguous
    /// and, within one, tips in one octant of the box come before the
    /// opposite octant's.
    #[test]
    fn the_order_groups_axes_then_tips() {
        let axes = [[0.0, 0.0, 1.0], [0.0, 0.7, 0.7], [0.0, 0.0, -1.0]];
        let mut queries = Vec::new();
        for k in 0..300 {
            let t = k as f32;
            let tip = [(t * 7.3) % 50.0, (t * 3.1) % 40.0, (t * 1.7) % 30.0];
            queries.push(query(tip, axes[k % 3]));
        }
        let order = coherent_order(&queries);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..300).collect::<Vec<u32>>());
        let cells: Vec<u32> = order
            .iter()
            .map(|&i| axis_cell(queries[i as usize].pose.cols[2]))
            .collect();
        let changes = cells.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(changes, 2, "{cells:?}");
        for run in cells.chunk_by(|a, b| a == b) {
            assert_eq!(run.len(), 100);
        }
        let (lo, scale) = tip_frame(&queries);
        let keys: Vec<u64> = order
            .iter()
            .map(|&i| key(&queries[i as usize], lo, scale))
            .collect();
        assert!(keys.windows(2).all(|w| w[0] <= w[1]));
        // Within a cell, the low-x low-y low-z octant (Morton's top bits 0)
        // comes first.
        let first = &queries[order[0] as usize].pose.tip;
        assert!(
            first[0] < 25.0 && first[1] < 20.0 && first[2] < 15.0,
            "{first:?}"
        );
    }

    #[test]
    fn one_query_or_none() {
        assert!(coherent_order(&[]).is_empty());
        assert_eq!(coherent_order(&[query([1.0; 3], [0.0, 0.0, 1.0])]), vec![0]);
    }
}
