//! No NaN reaches the GPU's buffers, nor an infinity (docs/SPEC.md §6, "What the kernel
//! assumes of the driver"): WGSL lets a compiler assume neither occurs, so a comparison that
//! only rejects a value because NaN compares false could take it on another driver. Every
//! f32 word the host uploads is checked before it is; which words are f32 is read from the
//! kernel's own declarations by naga's reflection (the element type of each binding's
//! array, or its struct), so a field added to a struct is checked without a list to keep.

use super::bindings::Binding;
use naga::{Module, Scalar, TypeInner};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::OnceLock;

/// Per binding: the bytes of one element and the byte offsets of its f32 values.
struct FloatLayout {
    stride: usize,
    floats: Vec<usize>,
}

fn layouts() -> &'static HashMap<u32, FloatLayout> {
    static LAYOUTS: OnceLock<HashMap<u32, FloatLayout>> = OnceLock::new();
    LAYOUTS.get_or_init(|| {
        let module = super::shader::module();
        let mut out = HashMap::new();
        for (_, global) in module.global_variables.iter() {
            let Some(binding) = &global.binding else { continue };
            let (element, stride) = match module.types[global.ty].inner {
                TypeInner::Array { base, stride, .. } => (base, stride as usize),
                _ => (global.ty, module.types[global.ty].inner.size(module.to_ctx()) as usize),
            };
            let mut floats = Vec::new();
            float_offsets(module, element, 0, &mut floats);
            out.insert(binding.binding, FloatLayout { stride, floats });
        }
        out
    })
}

/// The byte offsets, from `offset`, of the f32 values of type `ty`.
fn float_offsets(module: &Module, ty: naga::Handle<naga::Type>, offset: usize, out: &mut Vec<usize>) {
    match module.types[ty].inner {
        TypeInner::Scalar(s) if s == Scalar::F32 => out.push(offset),
        TypeInner::Vector { size, scalar } if scalar == Scalar::F32 => {
            out.extend((0..size as usize).map(|k| offset + 4 * k));
        }
        TypeInner::Array { base, size: naga::ArraySize::Constant(n), stride } => {
            for k in 0..n.get() as usize {
                float_offsets(module, base, offset + k * stride as usize, out);
            }
        }
        TypeInner::Struct { ref members, .. } => {
            for member in members {
                float_offsets(module, member.ty, offset + member.offset as usize, out);
            }
        }
        _ => {}
    }
}

/// The first f32 of `bytes`, the contents of binding `binding`, that is NaN or infinite:
/// which element and which byte of it, and the value.
pub fn first_non_finite(binding: Binding, bytes: &[u8]) -> Option<(usize, usize, f32)> {
    let layout = layouts().get(&binding.index())?;
    // Checked on every core; the first in the buffer's order is the one reported.
    bytes.par_chunks_exact(layout.stride.max(4)).enumerate().find_map_first(|(k, element)| {
        layout.floats.iter().find_map(|&at| {
            let value = f32::from_le_bytes(element[at..at + 4].try_into().expect("four bytes"));
            (!value.is_finite()).then_some((k, at, value))
        })
    })
}

/// How many f32 values one element of `binding` holds.
#[cfg(test)]
fn floats_per_element(binding: Binding) -> usize {
    layouts().get(&binding.index()).map_or(0, |l| l.floats.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{GpuTriangle, Params};

    #[test]
    fn reflection_finds_every_float_of_a_triangle_and_of_the_parameters() {
        // v0, v1, v2 (3 each) and the two octahedral coordinates; material is a u32.
        assert_eq!(floats_per_element(Binding::Triangles), 11);
        // direction, horizontal, up, background, ambient, grid_min, grid_cell, weight.
        assert_eq!(floats_per_element(Binding::Params), 3 * 7 + 1);
    }

    #[test]
    fn a_nan_or_an_infinity_is_found_where_it_is_and_a_u32_is_not_mistaken_for_one() {
        let mut triangles = [GpuTriangle::default(); 3];
        // A material index whose bits read as NaN is an index, not a float.
        triangles[0].material = 0x7fc0_0000;
        assert_eq!(first_non_finite(Binding::Triangles, bytemuck::cast_slice(&triangles)), None);
        triangles[2].normal_v = f32::NAN;
        let (k, at, v) = first_non_finite(Binding::Triangles, bytemuck::cast_slice(&triangles)).unwrap();
        assert_eq!((k, at), (2, 44));
        assert!(v.is_nan());
        let params = Params { weight: f32::INFINITY, ..Params::default() };
        assert!(first_non_finite(Binding::Params, bytemuck::bytes_of(&params)).is_some());
    }

    /// A noise of no octaves never changes its blend: its reach, infinite in f64, is uploaded
    /// as f32::MAX (a random scene found the infinity).
    #[test]
    fn a_texture_that_never_changes_uploads_a_finite_reach() {
        let text = "OrthographicCamera { center 0 0 -2 direction 0 0 0.103 up 0 0.667 0 size 1 }
            Materials { numMaterials 2 Material { diffuseColor 0 0 0 }
              Noise { Transform { UniformScale 0.3 } materialIndex 0 materialIndex 0 octaves 0 } }
            Group { numObjects 1 MaterialIndex 1 Sphere { center 0 0 0 radius 1 } }";
        let scene = crate::scene::parse_scene(text, std::path::Path::new("noise.txt")).unwrap();
        let rays = crate::camera::PrimaryRays::for_camera(&scene.camera, 8, 8);
        let buffers = crate::gpu::flatten::SceneBuffers::flattened(&scene, &rays);
        assert_eq!(buffers.textures[1].reach, f32::MAX);
        assert_eq!(first_non_finite(Binding::Textures, bytemuck::cast_slice(&buffers.textures)), None);
    }
}
