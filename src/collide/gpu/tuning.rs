//! How the gpu backend runs on an adapter: the options a caller may give
//! ([`GpuOptions`]), what they come to on a hardware or a software adapter
//! ([`GpuTuning`]), and the defaults behind them (measured on an H100 and
//! on lavapipe; BENCHMARKS.md).

/// Tuning of the GPU backend.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuOptions {
    /// Cap on one storage binding's size in bytes (default: the device's
    /// limit). Tests lower it to exercise split bindings on small scenes.
    pub max_binding_bytes: Option<u64>,
    /// Queries per dispatch (default: [`HARDWARE_BATCH`] on a hardware
    /// adapter, [`SOFTWARE_BATCH`] on a software one, within the device's
    /// limits).
    pub batch: Option<usize>,
    /// Slots of the candidate list per batch (default: 64 per query, within
    /// the device's limits). Tests lower it to make lists fill.
    pub capacity: Option<u32>,
    /// The most candidates one query hands over in one pass (default
    /// [`HARDWARE_PER_QUERY`] on a hardware adapter, [`PER_QUERY`] on a
    /// software one; `u32::MAX`: all of them at once).
    pub per_query: Option<u32>,
    /// Whether the walk uses subgroup operations, where the adapter has
    /// them (default: yes): persistent lanes that take the next query when
    /// their walk ends (`shaders/traverse_persistent.wgsl`). Tests turn it
    /// off to run the one-query-an-invocation kernel.
    pub subgroups: Option<bool>,
    /// With subgroups, whether the walk also reserves candidate slots one
    /// atomic per subgroup (default: on hardware adapters; lavapipe's
    /// atomics are a loop over the SIMD lanes either way, so there the
    /// subgroup's bookkeeping only adds instructions).
    pub subgroup_appends: Option<bool>,
    /// Whether each call's queries are walked in coherent order
    /// ([`crate::collide::order`]; default: on software adapters only).
    /// On lavapipe a group of 8 lanes walks as long as its longest lane,
    /// and neighbours in the order walk alike; on a hardware GPU ordering
    /// costs the host more than it saves the device.
    pub coherent: Option<bool>,
}

/// What [`GpuOptions`] come to on one adapter: each setting given, or the
/// adapter's default (before the device's limits bound the batch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuTuning {
    /// Queries per batch.
    pub batch: usize,
    /// The most candidates a query hands over a pass.
    pub per_query: u32,
    /// Persistent lanes (`shaders/traverse_persistent.wgsl`).
    pub subgroups: bool,
    /// Candidate slots reserved one atomic per subgroup.
    pub subgroup_appends: bool,
    /// Each call's queries walked in coherent order.
    pub coherent: bool,
}

impl GpuOptions {
    /// These options on `adapter`: where one is not given, the default
    /// for a hardware or a software adapter (measured on an H100 and on
    /// lavapipe; BENCHMARKS.md).
    pub fn tuned(&self, adapter: &super::AdapterSummary) -> GpuTuning {
        let hardware = adapter.hardware;
        let subgroups = self.subgroups.unwrap_or(true) && adapter.subgroups;
        GpuTuning {
            batch: self.batch.unwrap_or(if hardware {
                HARDWARE_BATCH
            } else {
                SOFTWARE_BATCH
            }),
            per_query: self
                .per_query
                .unwrap_or(if hardware {
                    HARDWARE_PER_QUERY
                } else {
                    PER_QUERY
                })
                .max(1),
            subgroups,
            subgroup_appends: subgroups && self.subgroup_appends.unwrap_or(hardware),
            coherent: self.coherent.unwrap_or(!hardware),
        }
    }
}

impl std::fmt::Display for GpuTuning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let walk = match (self.subgroups, self.subgroup_appends) {
            (false, _) => "one query an invocation",
            (true, false) => "persistent lanes",
            (true, true) => "persistent lanes, subgroup appends",
        };
        let order = if self.coherent {
            "coherent order"
        } else {
            "queries as given"
        };
        write!(
            f,
            "batches of {}, {} pairs a query a pass, {walk}, {order}",
            self.batch, self.per_query
        )
    }
}

/// Queries per batch on a hardware adapter: a large GPU keeps a few
/// hundred thousand invocations resident, and one batch should fill them
/// (BENCHMARKS.md, "On a real GPU").
pub const HARDWARE_BATCH: usize = 262_144;

/// Queries per batch on a software adapter (lavapipe): its invocations run
/// a few at a time on the CPU's cores, so a larger batch only delays the
/// first readback.
pub const SOFTWARE_BATCH: usize = 65_536;

/// Candidates a query hands over per pass on a hardware adapter. There a
/// resumed pass costs a round trip more than the walk it saves, and the
/// extra exact tests run in parallel, so a larger share pays.
pub const HARDWARE_PER_QUERY: u32 = 64;

/// Candidates a query hands over per pass by default on a software
/// adapter: a colliding query's first few pairs (nearer nodes walked
/// first) mostly settle it, so the rest are never tested; a query they do
/// not settle walks again for the next few.
pub const PER_QUERY: u32 = 16;

#[cfg(test)]
mod tests {
    use super::super::context::AdapterSummary;
    use super::*;

    fn adapter(hardware: bool, subgroups: bool) -> AdapterSummary {
        AdapterSummary {
            name: "test adapter".into(),
            backend: "Vulkan".into(),
            device_type: "test".into(),
            hardware,
            driver: "test".into(),
            limits: wgpu::Limits::default(),
            subgroups,
        }
    }

    #[test]
    fn defaults_follow_the_adapter_and_given_options_win() {
        let defaults = GpuOptions::default();
        assert_eq!(
            defaults.tuned(&adapter(true, true)),
            GpuTuning {
                batch: HARDWARE_BATCH,
                per_query: HARDWARE_PER_QUERY,
                subgroups: true,
                subgroup_appends: true,
                coherent: false,
            }
        );
        assert_eq!(
            defaults.tuned(&adapter(false, true)),
            GpuTuning {
                batch: SOFTWARE_BATCH,
                per_query: PER_QUERY,
                subgroups: true,
                subgroup_appends: false,
                coherent: true,
            }
        );
        // Without subgroups neither persistent lanes nor subgroup appends,
        // even when asked for.
        let asked = GpuOptions {
            subgroups: Some(true),
            subgroup_appends: Some(true),
            ..GpuOptions::default()
        };
        let t = asked.tuned(&adapter(true, false));
        assert!(!t.subgroups && !t.subgroup_appends);
        // Given settings win over the adapter's; a share of 0 is 1.
        let given = GpuOptions {
            batch: Some(7),
            per_query: Some(0),
            subgroups: Some(false),
            subgroup_appends: Some(true),
            coherent: Some(true),
            ..GpuOptions::default()
        };
        assert_eq!(
            given.tuned(&adapter(true, true)),
            GpuTuning {
                batch: 7,
                per_query: 1,
                subgroups: false,
                subgroup_appends: false,
                coherent: true,
            }
        );
        assert_eq!(
            defaults.tuned(&adapter(true, true)).to_string(),
            "batches of 262144, 64 pairs a query a pass, persistent lanes, subgroup appends, queries as given"
        );
    }
}
