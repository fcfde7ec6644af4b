//! Every WGSL kernel parses and validates with naga (no GPU needed), and the
//! WGSL structs have the sizes and field offsets of their Rust twins.

use maamplan::collide::gpu::shaders::{ALL, COLLIDE_REDUCE, COLLIDE_TRAVERSE};
use maamplan::scene::{
    GpuHeadParams, GpuMotion, GpuMove, GpuNode, GpuParams, GpuPartNode, GpuQuery, GpuTriangle,
};
use naga::valid::{Capabilities, ShaderStages, SubgroupOperationSet, ValidationFlags, Validator};

#[test]
fn every_shader_validates() {
    for (name, src) in ALL {
        let module = naga::front::wgsl::parse_str(src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
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

/// Constants the host and the kernels share have one value.
#[test]
fn shared_constants_match_rust() {
    let module = naga::front::wgsl::parse_str(COLLIDE_TRAVERSE).unwrap();
    let value = |name: &str| -> u32 {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no constant {name}"));
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v,
            ref e => panic!("{name} is {e:?}"),
        }
    };
    assert_eq!(
        value("STACK_SIZE") as usize,
        maamplan::scene::gpu_types::STACK_SIZE
    );
    assert_eq!(value("SUPPORT_SIDE"), maamplan::scene::slab::SUPPORT_SIDE);
    use maamplan::scene::gpu_types::{RESULT_HIT, RESULT_INCOMPLETE, RESULT_STORED_SHIFT};
    assert_eq!(value("RESULT_HIT"), RESULT_HIT);
    assert_eq!(value("RESULT_INCOMPLETE"), RESULT_INCOMPLETE);
    assert_eq!(value("RESULT_STORED_SHIFT"), RESULT_STORED_SHIFT);
    // The motion kernels have their own bindings and read the hit bit too.
    let reduce = naga::front::wgsl::parse_str(COLLIDE_REDUCE).unwrap();
    let hit_bit = reduce
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some("RESULT_HIT_BIT"))
        .map(|(_, c)| &reduce.global_expressions[c.init]);
    assert!(
        matches!(hit_bit, Some(naga::Expression::Literal(naga::Literal::U32(v))) if *v == RESULT_HIT),
        "RESULT_HIT_BIT is {hit_bit:?}"
    );
}

/// The members of the WGSL struct `name`.
fn struct_members<'m>(module: &'m naga::Module, name: &str) -> &'m [naga::StructMember] {
    let (_, t) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name}"));
    let naga::TypeInner::Struct { members, .. } = &t.inner else {
        panic!("{name} is a struct")
    };
    members
}

#[test]
fn struct_layouts_match_rust() {
    let module = naga::front::wgsl::parse_str(COLLIDE_TRAVERSE).unwrap();
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let size = |name: &str| -> u32 {
        let (h, _) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name}"));
        layouter[h].size
    };
    assert_eq!(
        size("Triangle") as usize,
        std::mem::size_of::<GpuTriangle>()
    );
    assert_eq!(size("Node") as usize, std::mem::size_of::<GpuNode>());
    assert_eq!(
        size("PartNode") as usize,
        std::mem::size_of::<GpuPartNode>()
    );
    assert_eq!(size("Query") as usize, std::mem::size_of::<GpuQuery>());
    assert_eq!(size("Params") as usize, std::mem::size_of::<GpuParams>());
    assert_eq!(size("Move") as usize, std::mem::size_of::<GpuMove>());
    assert_eq!(size("Motion") as usize, std::mem::size_of::<GpuMotion>());
    assert_eq!(
        size("HeadParams") as usize,
        std::mem::size_of::<GpuHeadParams>()
    );
    // Field offsets of the largest struct, where drift is most likely.
    let members = struct_members(&module, "HeadParams");
    let offsets: Vec<(String, u32)> = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
        .collect();
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
    // The query's cutoff and safety margin, which every kernel reads.
    let members = struct_members(&module, "Query");
    let offset = |name: &str| members.iter().find(|m| m.name.as_deref() == Some(name));
    assert_eq!(offset("cutoff").map(|m| m.offset), Some(48));
    assert_eq!(offset("margin").map(|m| m.offset), Some(52));
    let is_f32 = |m: &naga::StructMember| {
        matches!(
            module.types[m.ty].inner,
            naga::TypeInner::Scalar(naga::Scalar {
                kind: naga::ScalarKind::Float,
                width: 4
            })
        )
    };
    assert!(offset("margin").is_some_and(is_f32), "Query.margin is f32");
    let q = GpuQuery::default();
    let base = &q as *const _ as usize;
    assert_eq!(&q.cutoff as *const _ as usize - base, 48);
    assert_eq!(&q.margin as *const _ as usize - base, 52);
    // The batch's pass (first walk or resumed), which collide_traverse reads.
    let members = struct_members(&module, "Params");
    let resume = members.iter().find(|m| m.name.as_deref() == Some("resume"));
    assert_eq!(resume.map(|m| m.offset), Some(16));
    let g = GpuParams::default();
    assert_eq!(&g.resume as *const _ as usize - &g as *const _ as usize, 16);
    // And the Rust side, by construction of a value.
    let p = GpuHeadParams::default();
    let base = &p as *const _ as usize;
    assert_eq!(&p.inv_ray as *const _ as usize - base, 112);
    assert_eq!(&p.inv_cell as *const _ as usize - base, 124);
    assert_eq!(&p.grid_dims as *const _ as usize - base, 48);
    assert_eq!(&p.far_dims as *const _ as usize - base, 144);
    assert_eq!(&p.far_inv_cell as *const _ as usize - base, 160);
    assert_eq!(&p.support_offset as *const _ as usize - base, 164);
    assert_eq!(&p.plane_offset as *const _ as usize - base, 168);
    assert_eq!(&p.plane_origin as *const _ as usize - base, 176);
    assert_eq!(&p.plane_dims as *const _ as usize - base, 192);
}
