//! The kernel parses and validates with naga (no GPU needed), and every struct the host
//! uploads or reads back has exactly the size and field offsets naga reports for its WGSL
//! twin, so a field added on one side only cannot silently shift the others.

use raycaster::bvh::BvhNode;
use raycaster::gpu::layout::{
    BinItem, EyeTriangle, GpuEllipsoid, GpuLight, GpuMaterial, GpuPlane, GpuSphere, GpuTexture, GpuTriangle, Params,
    PixelLayout, PrimitiveKind, REF_KIND_SHIFT,
};
use raycaster::gpu::shader;
use raycaster::gpu::{Binding, KernelConfig};
use raycaster::render::{Outputs, SphereTest, TriangleTest};
use std::mem::{offset_of, size_of};

fn module() -> naga::Module {
    let source = shader::source();
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)))
}

/// (size, [(member name, offset)]) of the WGSL struct `name`.
fn wgsl_layout(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in the shader"));
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => {
            (*span, members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect())
        }
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

fn check(module: &naga::Module, name: &str, rust_size: usize, rust_offsets: &[(&str, usize)]) {
    let (size, members) = wgsl_layout(module, name);
    assert_eq!(size as usize, rust_size, "size of {name}");
    let wgsl: Vec<(String, u32)> = members.into_iter().filter(|(n, _)| !n.starts_with("_pad")).collect();
    let rust: Vec<(String, u32)> = rust_offsets.iter().map(|(n, o)| (n.to_string(), *o as u32)).collect();
    assert_eq!(wgsl, rust, "fields and offsets of {name}");
}

#[test]
fn shader_parses_and_validates() {
    let module = module();
    // Subgroups for main_bins_shared alone (gpu::specialise checks that the others need none).
    let capabilities = naga::valid::Capabilities::default() | naga::valid::Capabilities::SUBGROUP;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(shader::source())));
}

#[test]
fn host_structs_match_the_shader() {
    let m = module();
    check(
        &m,
        "Params",
        size_of::<Params>(),
        &[
            ("direction", offset_of!(Params, direction)),
            ("width", offset_of!(Params, width)),
            ("horizontal", offset_of!(Params, horizontal)),
            ("height", offset_of!(Params, height)),
            ("up", offset_of!(Params, up)),
            ("first_row", offset_of!(Params, first_row)),
            ("background", offset_of!(Params, background)),
            ("tile_rows", offset_of!(Params, tile_rows)),
            ("ambient", offset_of!(Params, ambient)),
            ("bin_columns", offset_of!(Params, bin_columns)),
            ("num_spheres", offset_of!(Params, num_spheres)),
            ("num_ellipsoids", offset_of!(Params, num_ellipsoids)),
            ("num_planes", offset_of!(Params, num_planes)),
            ("num_triangles", offset_of!(Params, num_triangles)),
            ("loop_canary_trips", offset_of!(Params, loop_canary_trips)),
            ("weight", offset_of!(Params, weight)),
            ("grid_nx", offset_of!(Params, grid_nx)),
            ("grid_ny", offset_of!(Params, grid_ny)),
            ("grid_min", offset_of!(Params, grid_min)),
            ("grid_nz", offset_of!(Params, grid_nz)),
            ("grid_cell", offset_of!(Params, grid_cell)),
            ("first_bin_row", offset_of!(Params, first_bin_row)),
            ("zero_bits", offset_of!(Params, zero_bits)),
            ("bounces", offset_of!(Params, bounces)),
            ("num_lights", offset_of!(Params, num_lights)),
            ("switches", offset_of!(Params, switches)),
        ],
    );
    check(
        &m,
        "Sphere",
        size_of::<GpuSphere>(),
        &[
            ("center", offset_of!(GpuSphere, center)),
            ("radius", offset_of!(GpuSphere, radius)),
            ("material", offset_of!(GpuSphere, material)),
        ],
    );
    check(
        &m,
        "Ellipsoid",
        size_of::<GpuEllipsoid>(),
        &[
            ("row0", offset_of!(GpuEllipsoid, rows)),
            ("row1", offset_of!(GpuEllipsoid, rows) + 16),
            ("row2", offset_of!(GpuEllipsoid, rows) + 32),
            ("material", offset_of!(GpuEllipsoid, material)),
        ],
    );
    check(
        &m,
        "Plane",
        size_of::<GpuPlane>(),
        &[
            ("normal", offset_of!(GpuPlane, normal)),
            ("offset", offset_of!(GpuPlane, offset)),
            ("material", offset_of!(GpuPlane, material)),
        ],
    );
    check(
        &m,
        "Triangle",
        size_of::<GpuTriangle>(),
        &[
            ("v0", offset_of!(GpuTriangle, v0)),
            ("material", offset_of!(GpuTriangle, material)),
            ("v1", offset_of!(GpuTriangle, v1)),
            ("normal_u", offset_of!(GpuTriangle, normal_u)),
            ("v2", offset_of!(GpuTriangle, v2)),
            ("normal_v", offset_of!(GpuTriangle, normal_v)),
        ],
    );
    check(
        &m,
        "Material",
        size_of::<GpuMaterial>(),
        &[
            ("diffuse", offset_of!(GpuMaterial, diffuse)),
            ("exponent", offset_of!(GpuMaterial, exponent)),
            ("specular", offset_of!(GpuMaterial, specular)),
            ("index_of_refraction", offset_of!(GpuMaterial, index_of_refraction)),
            ("reflective", offset_of!(GpuMaterial, reflective)),
            ("transparent", offset_of!(GpuMaterial, transparent)),
        ],
    );
    check(
        &m,
        "Texture",
        size_of::<GpuTexture>(),
        &[
            ("row0", offset_of!(GpuTexture, row0)),
            ("row1", offset_of!(GpuTexture, row1)),
            ("row2", offset_of!(GpuTexture, row2)),
            ("kind", offset_of!(GpuTexture, kind)),
            ("first", offset_of!(GpuTexture, first)),
            ("second", offset_of!(GpuTexture, second)),
            ("octaves", offset_of!(GpuTexture, octaves)),
            ("frequency", offset_of!(GpuTexture, frequency)),
            ("amplitude", offset_of!(GpuTexture, amplitude)),
            ("reach", offset_of!(GpuTexture, reach)),
            ("spawns", offset_of!(GpuTexture, spawns)),
        ],
    );
    check(
        &m,
        "Light",
        size_of::<GpuLight>(),
        &[
            ("to_light_or_position", offset_of!(GpuLight, to_light_or_position)),
            ("is_point", offset_of!(GpuLight, is_point)),
            ("color", offset_of!(GpuLight, color)),
            ("attenuation", offset_of!(GpuLight, attenuation)),
        ],
    );
    check(&m, "EyeTriangle", size_of::<EyeTriangle>(), &[("rows", offset_of!(EyeTriangle, edges))]);
    // The shader's rows 0 … 2 are the host's edges, row 3 its plane.
    assert_eq!(offset_of!(EyeTriangle, plane), offset_of!(EyeTriangle, edges) + 3 * 16);
    check(&m, "BinItem", size_of::<BinItem>(), &[("words", 0)]);
    // The shader names the host's fields by their word.
    for (name, offset) in [
        ("ITEM_REFERENCE", offset_of!(BinItem, reference)),
        ("ITEM_NEAR", offset_of!(BinItem, near)),
        ("ITEM_PIXELS", offset_of!(BinItem, pixels)),
    ] {
        assert_eq!(shader_constant(&m, name), naga::Literal::U32(offset as u32 / 4), "{name}");
    }
    check(
        &m,
        "Sampling",
        size_of::<raycaster::gpu::layout::GpuSampling>(),
        &[
            ("count", offset_of!(raycaster::gpu::layout::GpuSampling, count)),
            ("side", offset_of!(raycaster::gpu::layout::GpuSampling, side)),
            ("seed", offset_of!(raycaster::gpu::layout::GpuSampling, seed)),
            ("kind", offset_of!(raycaster::gpu::layout::GpuSampling, kind)),
            ("filter_kind", offset_of!(raycaster::gpu::layout::GpuSampling, filter_kind)),
            ("radius", offset_of!(raycaster::gpu::layout::GpuSampling, radius)),
            ("parameter", offset_of!(raycaster::gpu::layout::GpuSampling, parameter)),
            ("first_row", offset_of!(raycaster::gpu::layout::GpuSampling, first_row)),
            ("rows", offset_of!(raycaster::gpu::layout::GpuSampling, rows)),
        ],
    );
    check(
        &m,
        "BvhNode",
        size_of::<BvhNode>(),
        &[
            ("min", offset_of!(BvhNode, min)),
            ("first", offset_of!(BvhNode, first)),
            ("max", offset_of!(BvhNode, max)),
            ("count", offset_of!(BvhNode, count)),
        ],
    );
}

/// The elements the host uploads to each binding have the size the shader reads them with
/// (an array's stride, or a struct's size). The declarations themselves are generated from
/// the host's table (`gpu::Binding`); the WGSL types they name are written by hand in
/// `shaders/params.wgsl`, and so are the host's `#[repr(C)]` twins, which is what this holds
/// together. Each binding is found by its name, at its number, once.
#[test]
fn every_binding_holds_elements_of_the_shaders_size() {
    let m = module();
    let declared: Vec<(u32, String, u32)> = m
        .global_variables
        .iter()
        .filter_map(|(_, v)| {
            let binding = v.binding.as_ref()?;
            assert_eq!(binding.group, 0, "{:?}", v.name);
            let element = match m.types[v.ty].inner {
                naga::TypeInner::Array { stride, .. } => stride,
                naga::TypeInner::Struct { span, .. } => span,
                ref other => panic!("{:?}: unexpected type {other:?}", v.name),
            };
            Some((binding.binding, v.name.clone().unwrap_or_default(), element))
        })
        .collect();
    assert_eq!(declared.len(), Binding::ALL.len(), "{declared:?}");
    for binding in Binding::ALL {
        let found: Vec<_> = declared.iter().filter(|(_, name, _)| name == binding.name()).collect();
        assert_eq!(found.len(), 1, "{binding:?} is declared once");
        let (number, _, element) = found[0];
        assert_eq!(*number, binding.index(), "{binding:?}");
        assert_eq!(*element as u64, binding.element_bytes(), "{binding:?}: the shader's element and the host's");
    }
}

/// Every `override` the kernel declares is set by the host, and the host sets no other: a
/// constant renamed on one side only would otherwise be silently left at its default (or
/// fail pipeline creation at run time).
#[test]
fn override_constants_match_the_host() {
    let m = module();
    let mut shader: Vec<String> = m.overrides.iter().filter_map(|(_, o)| o.name.clone()).collect();
    shader.sort();
    let config = KernelConfig {
        has_spheres: true,
        has_ellipsoids: true,
        has_planes: true,
        has_triangles: true,
        orthographic: false,
        pixel_layout: PixelLayout { outputs: Outputs::ALL, packed: false },
        num_lights: 1,
        one_material: false,
        shade_back: false,
        specular: true,
        specular_fix: true,
        point_lights: true,
        shadows: true,
        tree: true,
        loop_canary: true,
        triangle_test: TriangleTest::Watertight,
        sphere_test: SphereTest::Robust,
        use_bvh: false,
        use_bins: false,
        shared_bin_loads: false,
        use_grid: false,
        textures: true,
        stats: true,
        voxels: true,
        stage: raycaster::gpu::Stage::Pixels,
        shared: false,
    };
    let mut host: Vec<String> = config.constants().iter().map(|(name, _)| name.to_string()).collect();
    host.sort();
    assert_eq!(shader, host);
}

/// The values the host passes for `TRIANGLE_TEST` and `SPHERE_TEST` name the same algorithms
/// in the shader (its `TRIANGLE_*` and `SPHERE_*` constants, which its dispatchers compare
/// against).
#[test]
fn algorithm_values_match_the_shader() {
    let m = module();
    let triangle = [
        ("TRIANGLE_CRAMER", TriangleTest::Cramer),
        ("TRIANGLE_MOLLER", TriangleTest::Moller),
        ("TRIANGLE_WATERTIGHT", TriangleTest::Watertight),
    ];
    for (name, test) in triangle {
        assert_eq!(shader_constant(&m, name), naga::Literal::U32(test as u32), "{name}");
    }
    for (name, test) in [("SPHERE_NAIVE", SphereTest::Naive), ("SPHERE_ROBUST", SphereTest::Robust)] {
        assert_eq!(shader_constant(&m, name), naga::Literal::U32(test as u32), "{name}");
    }
}

/// The value of the shader's `const NAME` (a literal).
fn shader_constant(module: &naga::Module, name: &str) -> naga::Literal {
    let (_, constant) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name} in the shader"));
    match module.global_expressions[constant.init] {
        naga::Expression::Literal(literal) => literal,
        ref other => panic!("{name} is not a literal: {other:?}"),
    }
}

/// The kernel's copies of the hierarchy's constants equal the builder's: its stack holds
/// the deepest tree the builder makes, and its box test widens by the same margin the CPU
/// traversal was checked with.
#[test]
fn bvh_constants_match_the_builder() {
    let m = module();
    assert_eq!(shader_constant(&m, "STACK_SIZE"), naga::Literal::U32(raycaster::bvh::STACK_SIZE as u32));
    match shader_constant(&m, "SLAB_MARGIN") {
        naga::Literal::F32(v) => assert_eq!(v, raycaster::bvh::SLAB_MARGIN, "{v:e}"),
        other => panic!("{other:?}"),
    }
}

/// The kernel numbers primitive kinds as the host does (`PrimitiveKind`, from which the
/// host encodes references into `prim_refs` and the bins), and decodes references with the
/// same shift.
#[test]
fn primitive_kinds_match_the_host() {
    let m = module();
    assert_eq!(PrimitiveKind::Triangle as u32, 0, "a triangle's reference is its index");
    for kind in PrimitiveKind::ALL {
        assert_eq!(shader_constant(&m, kind.wgsl_name()), naga::Literal::U32(kind as u32), "{kind:?}");
    }
    assert_eq!(shader_constant(&m, "REF_KIND_SHIFT"), naga::Literal::U32(REF_KIND_SHIFT));
    let kinds: Vec<String> =
        m.constants.iter().filter_map(|(_, c)| c.name.clone()).filter(|n| n.starts_with("KIND_")).collect();
    assert_eq!(kinds.len(), PrimitiveKind::ALL.len(), "{kinds:?}: a kind the host does not know");
}

/// The sizes the host dispatches and bins with are the kernel's: its workgroup (every entry
/// point), its packet of rays, and the sides of a bin it derives its bin index from.
#[test]
fn sizes_match_the_host() {
    let m = module();
    assert_eq!(shader_constant(&m, "PACKET"), naga::Literal::U32(raycaster::gpu::BIN_PACKET));
    assert_eq!(shader_constant(&m, "BIN_COLUMNS"), naga::Literal::U32(raycaster::gpu::binning::BIN_COLUMNS));
    assert_eq!(shader_constant(&m, "BIN_ROWS"), naga::Literal::U32(raycaster::gpu::binning::BIN_ROWS));
    assert_eq!(shader_constant(&m, "WORKGROUP"), naga::Literal::U32(raycaster::gpu::WORKGROUP));
    let names: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["main", "main_bins", "main_bins_shared", "main_samples", "main_samples_bins", "main_filter"]);
    for entry in &m.entry_points {
        let w = raycaster::gpu::WORKGROUP;
        // main_bins_shared's workgroups are main_bins' in one dimension (subgroup builtins).
        let size = if entry.name == "main_bins_shared" { [w * w, 1, 1] } else { [w, w, 1] };
        assert_eq!(entry.workgroup_size, size, "{}", entry.name);
    }
}

/// The any-hit query exists and has the signature shadow rays will call, though no entry
/// point calls it yet (validated with the rest by `shader_parses_and_validates`).
#[test]
fn any_hit_query_is_declared() {
    let m = module();
    let (_, f) =
        m.functions.iter().find(|(_, f)| f.name.as_deref() == Some("occluded")).expect("fn occluded in the kernel");
    let arguments: Vec<&str> = f.arguments.iter().filter_map(|a| a.name.as_deref()).collect();
    assert_eq!(arguments, ["ray", "tmin", "tmax"]);
    let result = f.result.as_ref().expect("occluded returns a value");
    assert_eq!(m.types[result.ty].inner, naga::TypeInner::Scalar(naga::Scalar::BOOL));
}

/// The host reads each `-stats` count as a high word times 2³² plus a low word, summed
/// over the slots (shaders/stats.wgsl carries into the high word when the low one wraps):
/// 3·2³² + 5 in one slot and 2³² − 1 in another make 4·2³² + 4.
#[test]
fn stats_counters_sum_high_and_low_words_over_the_slots() {
    use raycaster::gpu::layout::{sum_counters, STATS_SLOTS, STATS_WORDS};
    let mut words = vec![0u32; (STATS_SLOTS * STATS_WORDS) as usize];
    words[4] = 5; // slot 0, tests: low
    words[5] = 3; // slot 0, tests: high
    words[STATS_WORDS as usize + 4] = u32::MAX; // slot 1, tests: low
    words[(STATS_SLOTS as usize - 1) * STATS_WORDS as usize + 6] = 7; // last slot, cells
    let counted = sum_counters(&words);
    assert_eq!(counted.intersections, (4 << 32) + 4);
    assert_eq!(counted.cells_traversed, 7);
    assert_eq!((counted.non_shadow_rays, counted.shadow_rays), (0, 0));
}

/// Every entry point that reads a light or a material through the per-invocation copies
/// (`light_at`, `material_at`, shaders/shading.wgsl) loads them (`load_shading_data`): one
/// that forgot would shade with lights and materials of zero, silently.
#[test]
fn entry_points_that_shade_load_the_shading_data() {
    let m = module();
    let name_of = |h: naga::Handle<naga::Function>| m.functions[h].name.clone().unwrap_or_default();
    let reaches = |start: &naga::Block, name: &str| {
        let mut seen = std::collections::HashSet::new();
        let mut todo = calls(start);
        while let Some(f) = todo.pop() {
            if seen.insert(f) {
                todo.extend(calls(&m.functions[f].body));
            }
        }
        seen.iter().any(|&f| name_of(f) == name)
    };
    let mut shading = 0;
    for entry in &m.entry_points {
        if reaches(&entry.function.body, "light_at") || reaches(&entry.function.body, "material_at") {
            shading += 1;
            assert!(
                reaches(&entry.function.body, "load_shading_data"),
                "{} shades without load_shading_data",
                entry.name
            );
        }
    }
    // main, main_bins, main_bins_shared, main_samples, main_samples_bins.
    assert_eq!(shading, 5);
}

/// The functions a block calls, in its nested blocks too.
fn calls(block: &naga::Block) -> Vec<naga::Handle<naga::Function>> {
    let mut out = Vec::new();
    for statement in block.iter() {
        match statement {
            naga::Statement::Call { function, .. } => out.push(*function),
            naga::Statement::Block(b) => out.extend(calls(b)),
            naga::Statement::If { accept, reject, .. } => {
                out.extend(calls(accept));
                out.extend(calls(reject));
            }
            naga::Statement::Loop { body, continuing, .. } => {
                out.extend(calls(body));
                out.extend(calls(continuing));
            }
            naga::Statement::Switch { cases, .. } => cases.iter().for_each(|c| out.extend(calls(&c.body))),
            _ => {}
        }
    }
    out
}
