//! Deterministic query sets for benchmarks: each chosen waypoint's own pose
//! plus poses tilted around it, so both free and colliding poses are timed.

use crate::scene::Query;

/// Tilts (degrees) cycled through for the sampled poses.
pub const TILTS_DEG: [f64; 4] = [15.0, 30.0, 45.0, 60.0];

/// About `count` queries from `waypoints` (evenly strided): each chosen
/// waypoint's own pose followed by `tilted` poses at the angles of
/// [`TILTS_DEG`] and pseudo-random azimuths (fixed seed: reproducible).
pub fn tilted_queries(waypoints: &[Query], count: usize, tilted: usize) -> Vec<Query> {
    if waypoints.is_empty() || count == 0 {
        return Vec::new();
    }
    let per = tilted + 1;
    let chosen = count.div_ceil(per).min(waypoints.len()).max(1);
    let mut out = Vec::with_capacity(chosen * per);
    for k in 0..chosen {
        let q = waypoints[k * waypoints.len() / chosen];
        out.push(q);
        for t in 0..tilted {
            let h = splitmix(((k * per + t) as u64) ^ 0x9e37_79b9);
            let azimuth = (h >> 11) as f64 / (1u64 << 53) as f64 * std::f64::consts::TAU;
            let tilt = TILTS_DEG[t % TILTS_DEG.len()].to_radians();
            out.push(Query {
                pose: q.pose.tilted(tilt, azimuth),
                cutoff: q.cutoff,
                margin: q.margin,
                slope: q.slope,
            });
        }
    }
    out
}

fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}
