//! The kernel parses and validates with naga (no GPU needed), and every struct the host
//! uploads or reads back has exactly the size and field offsets naga reports for its WGSL
//! twin, so a field added on one side only cannot silently shift the others.

use raycaster::bvh::BvhNode;
use raycaster::gpu::layout::{GpuEllipsoid, GpuLight, GpuPlane, GpuSphere, GpuTriangle, Params};
use raycaster::gpu::SHADER_SOURCE;
use std::mem::{offset_of, size_of};

fn module() -> naga::Module {
    naga::front::wgsl::parse_str(SHADER_SOURCE).unwrap_or_else(|e| panic!("{}", e.emit_to_string(SHADER_SOURCE)))
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
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(SHADER_SOURCE)));
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
            ("num_spheres", offset_of!(Params, num_spheres)),
            ("num_ellipsoids", offset_of!(Params, num_ellipsoids)),
            ("num_planes", offset_of!(Params, num_planes)),
            ("num_triangles", offset_of!(Params, num_triangles)),
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
            ("v2", offset_of!(GpuTriangle, v2)),
        ],
    );
    check(
        &m,
        "Light",
        size_of::<GpuLight>(),
        &[("to_light", offset_of!(GpuLight, to_light)), ("color", offset_of!(GpuLight, color))],
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

/// Each binding's array stride equals the size of the Rust element uploaded to it
/// (materials travel as `array<vec4<f32>>`, i.e. `[f32; 4]`).
#[test]
fn binding_strides_match() {
    let m = module();
    let expected = [
        (1, size_of::<GpuSphere>()),
        (2, size_of::<GpuEllipsoid>()),
        (3, size_of::<GpuPlane>()),
        (4, size_of::<GpuTriangle>()),
        (5, size_of::<[f32; 4]>()),
        (6, size_of::<GpuLight>()),
        (7, size_of::<u32>()),
        (8, size_of::<BvhNode>()),
        (9, size_of::<u32>()),
    ];
    for (binding, rust_size) in expected {
        let (_, var) = m
            .global_variables
            .iter()
            .find(|(_, v)| v.binding.as_ref().map(|b| (b.group, b.binding)) == Some((0, binding)))
            .unwrap_or_else(|| panic!("no binding {binding}"));
        match m.types[var.ty].inner {
            naga::TypeInner::Array { stride, .. } => {
                assert_eq!(stride as usize, rust_size, "stride of binding {binding}")
            }
            ref other => panic!("binding {binding} is not an array: {other:?}"),
        }
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
    let refs = [
        ("REF_TRIANGLE", raycaster::gpu::layout::REF_TRIANGLE),
        ("REF_SPHERE", raycaster::gpu::layout::REF_SPHERE),
        ("REF_ELLIPSOID", raycaster::gpu::layout::REF_ELLIPSOID),
    ];
    for (name, value) in refs {
        assert_eq!(shader_constant(&m, name), naga::Literal::U32(value), "{name}");
    }
}
