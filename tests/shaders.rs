//! Every WGSL kernel parses and validates with naga (no GPU needed), and the
//! WGSL structs have the sizes and field offsets of their Rust twins.

use maamplan::collide::gpu::shaders::{ALL, COLLIDE_REDUCE, COLLIDE_TRAVERSE};
use maamplan::collide::gpu::wire::{
    GpuMotion, GpuMove, GpuParams, RESULT_HIT, RESULT_INCOMPLETE, RESULT_STORED_SHIFT,
};
use maamplan::scene::{GpuHeadParams, GpuNode, GpuPartNode, GpuQuery, GpuTriangle};
use naga::valid::{Capabilities, ShaderStages, SubgroupOperationSet, ValidationFlags, Validator};

#[test]
fn every_shader_validates() {
    for (name, src) in ALL {
        let module = parsed(name, src);
        // Only the kernels built for adapters with subgroups may use them;
        // all may unpack halves (adapters are chosen for it, context.rs).
        let halves = Capabilities::SHADER_FLOAT16_IN_FLOAT32;
        let mut v = if name.contains("(subgroups)") {
            let mut v = Validator::new(ValidationFlags::all(), Capabilities::SUBGROUP | halves);
            v.subgroup_stages(ShaderStages::COMPUTE);
            v.subgroup_operations(SubgroupOperationSet::all());
            v
        } else {
            Validator::new(ValidationFlags::all(), halves)
        };
        v.validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
    }
}

/// `src` parsed, or a panic naming `what`.
fn parsed(what: &str, src: &str) -> naga::Module {
    naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{what}: {}", e.emit_to_string(src)))
}

/// The value of the `u32` constant `name` in `module`, if it has one.
fn u32_constant(module: &naga::Module, name: &str) -> Option<u32> {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))?;
    match module.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => Some(v),
        _ => None,
    }
}

/// The type named `name` in `module`.
fn named_type(module: &naga::Module, name: &str) -> naga::Handle<naga::Type> {
    module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .map(|(h, _)| h)
        .unwrap_or_else(|| panic!("no type {name}"))
}

/// The members of the WGSL struct `name`.
fn struct_members<'m>(module: &'m naga::Module, name: &str) -> &'m [naga::StructMember] {
    let naga::TypeInner::Struct { members, .. } = &module.types[named_type(module, name)].inner
    else {
        panic!("{name} is a struct")
    };
    members
}

/// The byte offset of each member of the WGSL struct `name`.
fn member_offsets(module: &naga::Module, name: &str) -> Vec<(String, u32)> {
    struct_members(module, name)
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
        .collect()
}

/// The offset of member `member` of the WGSL struct `name`.
fn member_offset(module: &naga::Module, name: &str, member: &str) -> Option<u32> {
    member_offsets(module, name)
        .into_iter()
        .find(|(n, _)| n == member)
        .map(|(_, o)| o)
}

/// The offset of a field in a Rust value, from pointers to both.
fn offset_in<T, F>(value: &T, field: &F) -> usize {
    field as *const F as usize - value as *const T as usize
}

/// Constants the walk kernels and the host share have one value.
#[test]
fn shared_constants_match_rust() {
    let module = parsed("collide_traverse", COLLIDE_TRAVERSE);
    let value = |name: &str| u32_constant(&module, name).unwrap_or_else(|| panic!("no {name}"));
    assert_eq!(
        value("STACK_SIZE") as usize,
        maamplan::collide::cpu::common::STACK_SIZE
    );
    assert_eq!(
        value("SUPPORT_SIDE"),
        maamplan::collide::cpu::common::SUPPORT_SIDE
    );
    assert_eq!(value("RESULT_HIT"), RESULT_HIT);
    assert_eq!(value("RESULT_INCOMPLETE"), RESULT_INCOMPLETE);
    assert_eq!(value("RESULT_STORED_SHIFT"), RESULT_STORED_SHIFT);
}

/// The motion kernels have their own bindings and read the hit bit too.
#[test]
fn the_reduction_reads_the_hosts_hit_bit() {
    let reduce = parsed("collide_reduce", COLLIDE_REDUCE);
    assert_eq!(u32_constant(&reduce, "RESULT_HIT_BIT"), Some(RESULT_HIT));
}

#[test]
fn struct_sizes_match_rust() {
    let module = parsed("collide_traverse", COLLIDE_TRAVERSE);
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let size = |name: &str| layouter[named_type(&module, name)].size as usize;
    use std::mem::size_of;
    assert_eq!(size("Triangle"), size_of::<GpuTriangle>());
    assert_eq!(size("Node"), size_of::<GpuNode>());
    assert_eq!(size("PartNode"), size_of::<GpuPartNode>());
    assert_eq!(size("Query"), size_of::<GpuQuery>());
    assert_eq!(size("Params"), size_of::<GpuParams>());
    assert_eq!(size("Move"), size_of::<GpuMove>());
    assert_eq!(size("Motion"), size_of::<GpuMotion>());
    assert_eq!(size("HeadParams"), size_of::<GpuHeadParams>());
}

/// Field offsets of the largest struct, where drift is most likely, on
/// both sides.
#[test]
fn head_params_fields_sit_where_rust_puts_them() {
    let module = parsed("collide_traverse", COLLIDE_TRAVERSE);
    let offsets = member_offsets(&module, "HeadParams");
    let want = [
        ("aabb_min", 0),
        ("tol", 12),
        ("aabb_max", 16),
        ("grid_slack", 28),
        ("grid_origin", 32),
        ("cell", 44),
        ("grid_dims", 48),
        ("tri_count", 60),
        ("ray_a", 64),
        ("ray_b", 80),
        ("ray_d", 96),
        ("inv_ray", 112),
        ("inv_cell", 124),
        ("far_origin", 128),
        ("far_cell", 140),
        ("far_dims", 144),
        ("far_offset", 156),
        ("far_inv_cell", 160),
        ("support_offset", 164),
        ("plane_offset", 168),
        ("plane_inv_cell", 172),
        ("plane_origin", 176),
        ("plane_cell", 188),
        ("plane_dims", 192),
    ];
    for (name, off) in want {
        let got = offsets.iter().find(|(n, _)| n == name).map(|(_, o)| *o);
        assert_eq!(got, Some(off), "HeadParams.{name}");
    }
    let p = GpuHeadParams::default();
    assert_eq!(offset_in(&p, &p.grid_dims), 48);
    assert_eq!(offset_in(&p, &p.inv_ray), 112);
    assert_eq!(offset_in(&p, &p.inv_cell), 124);
    assert_eq!(offset_in(&p, &p.far_dims), 144);
    assert_eq!(offset_in(&p, &p.far_inv_cell), 160);
    assert_eq!(offset_in(&p, &p.support_offset), 164);
    assert_eq!(offset_in(&p, &p.plane_offset), 168);
    assert_eq!(offset_in(&p, &p.plane_origin), 176);
    assert_eq!(offset_in(&p, &p.plane_dims), 192);
}

/// The query's cutoff and safety margin, which every kernel reads.
#[test]
fn query_cutoff_and_margin_sit_where_rust_puts_them() {
    let module = parsed("collide_traverse", COLLIDE_TRAVERSE);
    assert_eq!(member_offset(&module, "Query", "cutoff"), Some(48));
    assert_eq!(member_offset(&module, "Query", "margin"), Some(52));
    let margin = struct_members(&module, "Query")
        .iter()
        .find(|m| m.name.as_deref() == Some("margin"));
    let is_f32 = |m: &&naga::StructMember| {
        matches!(
            module.types[m.ty].inner,
            naga::TypeInner::Scalar(naga::Scalar {
                kind: naga::ScalarKind::Float,
                width: 4
            })
        )
    };
    assert!(margin.is_some_and(|m| is_f32(&m)), "Query.margin is f32");
    let q = GpuQuery::default();
    assert_eq!(offset_in(&q, &q.cutoff), 48);
    assert_eq!(offset_in(&q, &q.margin), 52);
}

/// The batch's pass (first walk or resumed), which collide_traverse reads.
#[test]
fn params_resume_sits_where_rust_puts_it() {
    let module = parsed("collide_traverse", COLLIDE_TRAVERSE);
    assert_eq!(member_offset(&module, "Params", "resume"), Some(16));
    let g = GpuParams::default();
    assert_eq!(offset_in(&g, &g.resume), 16);
}
