//! The ray tree's shape, worked out on the host before the kernel is chosen: how deep the
//! kernel's tree (`shaders/tree.wgsl`) can go for this scene and these flags, how many rays
//! a primary ray's tree holds at most, and whether the kernel's stack holds it. A tree that
//! does not fit is refused ([`super::support`]), so `auto` renders it with the reference
//! rather than cut it short.

use crate::render::Shading;
use crate::scene::Scene;

/// Slots of the kernel's stack of rays waiting to be traced: a tree `BOUNCES` deep needs
/// `BOUNCES + 1` (the kernel's `TREE_STACK`), so it goes 15 bounces deep at most. Each slot
/// holds 13 words of private memory per invocation. The course's deepest tree is 10
/// (scene4_05 with `-bounces 10`).
pub const TREE_STACK: u32 = 16;

/// What the kernel's tree looks like for one scene and one set of shading flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeShape {
    /// The depth the kernel is compiled with (`BOUNCES`): `-bounces`, lowered to the depth
    /// at which every path's weight has fallen below `-weight`, and to 0 when no material
    /// reflects or transmits.
    pub depth: u32,
    /// The most rays a primary ray's tree holds, the primary ray included (shadow rays not).
    pub max_rays: u64,
}

impl TreeShape {
    /// The shape for `scene` shaded as `shading` says. A ray `d` bounces deep that took `k`
    /// reflections carries at most the weight `r^k · t^(d−k)`, where `r` and `t` are the
    /// largest lengths of a reflective and a transparent colour in the scene: it is traced
    /// only if that reaches `-weight` (docs/SPEC.md §5), so the tree holds at most
    /// `C(d, k)` such rays per depth and split.
    pub fn new(scene: &Scene, shading: &Shading) -> TreeShape {
        let longest = |colour: fn(&crate::scene::Material) -> glam::DVec3| {
            scene.materials.iter().map(|m| colour(m).length()).fold(0.0, f64::max)
        };
        let (r, t) = (longest(|m| m.reflective), longest(|m| m.transparent));
        // The kernel compares f32 products: allow them a little above the f64 bound.
        let threshold = shading.weight * (1.0 - 1e-5);
        let mut shape = TreeShape { depth: 0, max_rays: 1 };
        // Paths of depth d by reflections taken: C(d, k), kept while their weight can pass.
        let mut row: Vec<u64> = vec![1];
        for d in 1..=shading.bounces.min(64) {
            let mut next = vec![0u64; d as usize + 1];
            for (k, count) in row.iter().enumerate() {
                next[k] = next[k].saturating_add(*count);
                next[k + 1] = next[k + 1].saturating_add(*count);
            }
            let alive = next
                .iter()
                .enumerate()
                .map(|(k, count)| {
                    let weight = r.powi(k as i32) * t.powi((d as usize - k) as i32);
                    if weight > 0.0 && weight >= threshold {
                        *count
                    } else {
                        0
                    }
                })
                .fold(0u64, u64::saturating_add);
            if alive == 0 {
                break;
            }
            shape.depth = d;
            shape.max_rays = shape.max_rays.saturating_add(alive);
            row = next;
        }
        if shading.bounces > 64 && shape.depth == 64 {
            // Deeper than anything the kernel holds: only the depth matters for the refusal.
            shape.depth = shading.bounces;
            shape.max_rays = u64::MAX;
        }
        shape
    }

    /// Whether the kernel's stack holds the tree.
    pub fn fits_stack(&self) -> bool {
        self.depth < TREE_STACK
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
        assert_eq!(shape, TreeShape { depth: 3, max_rays: 15 });
    }

    #[test]
    fn a_mirror_alone_makes_a_chain() {
        let shape = TreeShape::new(&scene("0.5 0 0", "0 0 0"), &shading(10, 0.0));
        assert_eq!(shape, TreeShape { depth: 10, max_rays: 11 });
    }

    /// 0.5^6 = 0.0156 ≥ 0.01 > 0.5^7: the weight stops a mirror chain at depth 6.
    #[test]
    fn the_weight_stops_the_tree() {
        let shape = TreeShape::new(&scene("0.5 0 0", "0 0 0"), &shading(10, 0.01));
        assert_eq!(shape, TreeShape { depth: 6, max_rays: 7 });
        // Reflective 0.5, transparent 0.25: depth 2 keeps 0.25 (r·r), 0.125 (r·t, twice),
        // not t·t = 0.0625 below 0.1.
        let shape = TreeShape::new(&scene("0.5 0 0", "0.25 0 0"), &shading(5, 0.1));
        assert_eq!(shape, TreeShape { depth: 3, max_rays: 1 + 2 + 3 + 1 });
    }

    #[test]
    fn no_bounce_without_a_reflective_or_transparent_material() {
        let shape = TreeShape::new(&scene("0 0 0", "0 0 0"), &shading(5, 0.0));
        assert_eq!(shape, TreeShape { depth: 0, max_rays: 1 });
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
}
