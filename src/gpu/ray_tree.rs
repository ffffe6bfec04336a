//! The ray tree's shape, worked out on the host before the kernel is chosen: how deep the
//! kernel's tree (`shaders/tree.wgsl`) can go for this scene and these flags, and whether
//! the kernel's stack holds it. A tree that does not fit is refused ([`super::unsupported`]),
//! so `auto` renders it with the reference rather than cut it short.

use crate::render::{RenderOptions, Shading};
use crate::scene::Scene;
use glam::DVec3;

/// Slots of the kernel's stack of rays waiting to be traced. A node's children wait there
/// while the last pushed is traced, so a tree `d` deep whose nodes spawn at most `c` rays
/// needs `1 + d·(c − 1)` ([`TreeShape::slots`]): 15 bounces deep for a Phong material's two
/// rays. Each slot holds 13 words of private memory per invocation. The course's deepest
/// tree is 10 (scene4_05 with `-bounces 10`).
pub const TREE_STACK: u32 = 16;

/// The rays a render traces beyond the primary ones: its ray tree and its shadow rays. The
/// one rule for "secondary rays", which the kernel's configuration, the choice of how rays
/// find their candidates and `auto`'s choice of renderer all follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderRays {
    pub tree: TreeShape,
    /// Shadow rays: `-shadows` in a scene with lights.
    pub shadows: bool,
}

impl RenderRays {
    /// The rays a render of `scene` as `options` say traces. The `-visualize_grid` picture
    /// traces primary rays only and shades cells, never a material.
    pub fn new(scene: &Scene, options: &RenderOptions) -> RenderRays {
        if options.visualize_grid {
            let primary = Shading { bounces: 0, shadows: false, ..options.shading };
            return RenderRays { tree: TreeShape::new(scene, &primary), shadows: false };
        }
        let shadows = options.shading.shadows && !scene.lights.is_empty();
        RenderRays { tree: TreeShape::new(scene, &options.shading), shadows }
    }

    /// Whether rays other than primary ones are traced (shadow, reflected, refracted).
    pub fn secondary(&self) -> bool {
        self.shadows || self.tree.depth > 0
    }
}

/// What the kernel's tree looks like for one scene and one set of shading flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeShape {
    /// The depth the kernel is compiled with (`BOUNCES`): `-bounces`, lowered to the depth
    /// at which every path's weight has fallen below `-weight`, and to 0 when no material
    /// reflects or transmits.
    pub depth: u32,
    /// The most rays a hit spawns ([`branching`]), taken as at least 2.
    pub spawned: u32,
}

impl TreeShape {
    /// The shape for `scene` shaded as `shading` says. A ray `d` bounces deep that took `k`
    /// reflections carries at most the weight `r^k · t^(d−k)`, where `r` and `t` are the
    /// largest lengths of a reflective and a transparent colour in the scene (a solid
    /// texture's materials each spawn their own rays with their own colours): it is traced
    /// only if that reaches `-weight` (docs/SPEC.md §5).
    pub fn new(scene: &Scene, shading: &Shading) -> TreeShape {
        let longest = |colour: fn(&crate::scene::Material) -> DVec3| {
            scene.materials.iter().map(|m| colour(m).length()).fold(0.0, f64::max)
        };
        let (r, t) = (longest(|m| m.reflective), longest(|m| m.transparent));
        // The kernel compares f32 products: allow them a little above the f64 bound.
        let threshold = shading.weight * (1.0 - 1e-5);
        let alive = |d: u32| {
            (0..=d).any(|k| {
                let weight = r.powi(k as i32) * t.powi((d - k) as i32);
                weight > 0.0 && weight >= threshold
            })
        };
        // A deeper tree than the stack can hold only needs to be known as one.
        let depth = (1..=shading.bounces.min(TREE_STACK * 4)).take_while(|&d| alive(d)).last().unwrap_or(0);
        let depth = if depth == TREE_STACK * 4 { shading.bounces } else { depth };
        let spawned = (0..scene.materials.len() as u32).map(|m| branching(scene, m)).max().unwrap_or(0);
        TreeShape { depth, spawned: spawned.max(2) }
    }

    /// The stack slots the tree needs at most: `1 + depth · (spawned − 1)`.
    pub fn slots(&self) -> u64 {
        1 + self.depth as u64 * (self.spawned as u64 - 1)
    }

    /// The deepest tree of this branching the stack holds.
    pub fn deepest(&self) -> u32 {
        (TREE_STACK - 1) / (self.spawned - 1)
    }

    /// Whether the kernel's stack holds the tree.
    pub fn fits_stack(&self) -> bool {
        self.slots() <= TREE_STACK as u64
    }
}

/// How many rays a hit on material `index` may spawn: one for a reflective colour and one
/// for a transparent one; a solid texture, those of every material it blends (the kernel
/// pushes each one's rays, weighted by its share: `shaders/tree.wgsl`).
pub fn branching(scene: &Scene, index: u32) -> u32 {
    match scene.texture(index) {
        Some(texture) => texture.materials.iter().map(|&m| branching(scene, m)).sum(),
        None => {
            let material = &scene.materials[index as usize];
            (material.reflective != DVec3::ZERO) as u32 + (material.transparent != DVec3::ZERO) as u32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene;
    use std::path::Path;

    fn scene(reflective: &str, transparent: &str) -> Scene {
        let text = format!(
            "OrthographicCamera {{ center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }}
             Background {{ color 0 0 0 }}
             Materials {{ numMaterials 1 PhongMaterial {{ diffuseColor 1 1 1
               reflectiveColor {reflective} transparentColor {transparent} indexOfRefraction 1.5 }} }}
             Group {{ numObjects 1 MaterialIndex 0 Sphere {{ center 0 0 0 radius 1 }} }}"
        );
        parse_scene(&text, Path::new("tree.txt")).unwrap()
    }

    fn shading(bounces: u32, weight: f64) -> Shading {
        Shading { bounces, weight, ..Shading::default() }
    }

    #[test]
    fn a_full_binary_tree_without_a_weight() {
        let shape = TreeShape::new(&scene("1 0 0", "1 0 0"), &shading(3, 0.0));
        assert_eq!(shape, TreeShape { depth: 3, spawned: 2 });
    }

    #[test]
    fn a_mirror_alone_makes_a_chain() {
        let shape = TreeShape::new(&scene("0.5 0 0", "0 0 0"), &shading(10, 0.0));
        assert_eq!(shape, TreeShape { depth: 10, spawned: 2 });
    }

    /// 0.5^6 = 0.0156 ≥ 0.01 > 0.5^7: the weight stops a mirror chain at depth 6.
    #[test]
    fn the_weight_stops_the_tree() {
        let shape = TreeShape::new(&scene("0.5 0 0", "0 0 0"), &shading(10, 0.01));
        assert_eq!(shape, TreeShape { depth: 6, spawned: 2 });
        // Reflective 0.5, transparent 0.25: depth 2 keeps 0.25 (r·r), 0.125 (r·t, twice),
        // not t·t = 0.0625 below 0.1.
        let shape = TreeShape::new(&scene("0.5 0 0", "0.25 0 0"), &shading(5, 0.1));
        assert_eq!(shape, TreeShape { depth: 3, spawned: 2 });
    }

    #[test]
    fn no_bounce_without_a_reflective_or_transparent_material() {
        let shape = TreeShape::new(&scene("0 0 0", "0 0 0"), &shading(5, 0.0));
        assert_eq!(shape, TreeShape { depth: 0, spawned: 2 });
        assert!(shape.fits_stack());
    }

    #[test]
    fn deep_trees_do_not_fit_the_stack() {
        let shape = TreeShape::new(&scene("1 0 0", "0 0 0"), &shading(1000, 0.0));
        assert_eq!(shape.depth, 1000);
        assert!(!shape.fits_stack());
        assert!(TreeShape::new(&scene("1 0 0", "0 0 0"), &shading(TREE_STACK - 1, 0.0)).fits_stack());
        assert!(!TreeShape::new(&scene("1 0 0", "0 0 0"), &shading(TREE_STACK, 0.0)).fits_stack());
    }

    /// A checkerboard of a mirror and glass spawns three rays where it hits (the mirror's
    /// reflection, the glass's reflection and refraction): a tree d deep waits 2 per level.
    #[test]
    fn a_texture_spawns_the_rays_of_every_material_it_blends() {
        let text = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
             Materials { numMaterials 4
               PhongMaterial { diffuseColor 1 1 1 reflectiveColor 0.5 0.5 0.5 }
               PhongMaterial { diffuseColor 1 1 1 reflectiveColor 0.5 0.5 0.5 transparentColor 0.5 0.5 0.5 indexOfRefraction 1.5 }
               PhongMaterial { diffuseColor 1 1 1 }
               Checkerboard { materialIndex 0 materialIndex 1 } }
             Group { numObjects 1 MaterialIndex 3 Sphere { center 0 0 0 radius 1 } }";
        let scene = parse_scene(text, Path::new("tree.txt")).unwrap();
        assert_eq!([0, 1, 2, 3].map(|m| branching(&scene, m)), [1, 2, 0, 3]);
        assert_eq!(TreeShape::new(&scene, &shading(5, 0.0)), TreeShape { depth: 5, spawned: 3 });
        assert_eq!(TreeShape::new(&scene, &shading(5, 0.0)).slots(), 11);
        assert_eq!(TreeShape::new(&scene, &shading(5, 0.0)).deepest(), 7);
        assert!(TreeShape::new(&scene, &shading(7, 0.0)).fits_stack(), "1 + 7·2 = 15 slots");
        assert!(!TreeShape::new(&scene, &shading(8, 0.0)).fits_stack(), "1 + 8·2 = 17 slots");
    }
}
