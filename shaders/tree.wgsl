// uses: host, params, exact, ray, closest, nearest, surface, texture, shading
// The ray tree of docs/SPEC.md §5 without recursion, which WGSL does not have: the rays
// still to trace wait on an explicit stack, depth first. A node pushes its children
// (reflected and refracted, for each material a solid texture blends) one level deeper and
// the last pushed is traced next, so at most all but one of a node's children wait per
// level: the host keeps that within TREE_STACK (gpu::ray_tree::TreeShape::slots). The colour is linear in what each ray sees, so each ray adds its
// own shading times the product of the colours on its way from the camera, in whatever
// order the stack hands it out.

// A ray still to trace.
struct Pending {
    ray: Ray,
    // The product of the reflective and transparent colours on its way from the camera.
    throughput: vec3<f32>,
    // The product of their lengths, the weight -weight compares.
    weight: f32,
    // The index of refraction of the medium it travels in.
    index: f32,
    // Reflections and refractions so far.
    bounces: u32,
}

// The stack, packed in three arrays of vec4 (origin and weight, direction and index,
// throughput and bounces): lavapipe compiled the array of structs 10 times slower.
var<private> pending_origin: array<vec4<f32>, TREE_STACK>;
var<private> pending_direction: array<vec4<f32>, TREE_STACK>;
var<private> pending_throughput: array<vec4<f32>, TREE_STACK>;
var<private> pending_len: u32;

fn push_pending(p: Pending) {
    pending_origin[pending_len] = vec4<f32>(p.ray.origin, p.weight);
    pending_direction[pending_len] = vec4<f32>(p.ray.direction, p.index);
    pending_throughput[pending_len] = vec4<f32>(p.throughput, bitcast<f32>(p.bounces));
    pending_len += 1u;
}

fn pop_pending() -> Pending {
    pending_len -= 1u;
    let o = pending_origin[pending_len];
    let d = pending_direction[pending_len];
    let t = pending_throughput[pending_len];
    return Pending(Ray(o.xyz, d.xyz), t.xyz, o.w, d.w, bitcast<u32>(t.w));
}

// Set where a reflected or refracted ray traced for the pixel left its surface grazing it
// (Leaving::grazing in shaders/surface.wgsl): the f32 kernel cannot start it faithfully, so
// the pixel is handed over to the reference, as one beyond a texture's reach is.
var<private> spawned_grazing: bool;

// Queues the ray `leaving` a surface, whose colour counts `share` · `tint` times: not at
// all where the tint is black or the weight it would carry falls below -weight. The weight
// leaves the share out, as the reference's path weight does (a texture's materials each
// spawn their own rays).
fn push_ray(leaving: Leaving, tint: vec3<f32>, share: f32, parent: Pending, index: f32) {
    let weight = parent.weight * length(tint);
    if (all(tint == vec3<f32>(0.0)) || weight < P.weight) {
        return;
    }
    if (leaving.grazing) {
        spawned_grazing = true;
    }
    push_pending(Pending(leaving.ray, parent.throughput * (share * tint), weight, index, parent.bounces + 1u));
}

// The direction of the unit ray d refracted at a surface whose unit normal n faces it, from
// index_from into index_to (Snell's law, as cpu::refract); w = 0 at total internal
// reflection. k = 1 − η²(1 − cos²) is computed as (1 − η)(1 + η) + η²cos² (docs/SPEC.md §5):
// the first form rounds 1 − cos² to 1 below cos ≈ 2⁻¹², so a grazing ray between equal
// indices (η = 1, k = cos²) was taken for total internal reflection.
fn refraction(d: vec3<f32>, n: vec3<f32>, index_from: f32, index_to: f32) -> vec4<f32> {
    let eta = index_from / index_to;
    let cos_in = -dot3(d, n);
    // Whether the ray is reflected whole (k < 0) is a decision: products rounded.
    let k = rounded((1.0 - eta) * (1.0 + eta)) + rounded(rounded(eta * eta) * rounded(cos_in * cos_in));
    if (k < 0.0) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(normalize(rounded3(eta * d) + rounded3((rounded(eta * cos_in) - sqrt(k)) * n)), 1.0);
}

// The reflected and refracted rays of the surface `node.ray` hit, while the tree may go
// deeper: its material's, or those of each material a solid texture blends there, by
// its share (docs/SPEC.md §5).
fn push_children(surface: Surface, node: Pending) {
    if (node.bounces >= P.bounces || is_black(surface, node.ray)) {
        return;
    }
    if (TEXTURES && textures[surface.material].kind != 0u) {
        if (textures[surface.material].spawns == 0u) {
            return;
        }
        start_blend(surface.material);
        let cosine = cosine_to(surface, node.ray);
        loop {
            let leaf = next_leaf(surface.point, cosine);
            if (leaf.material == NO_LEAF) {
                break;
            }
            push_material_children(surface, node, material_at(leaf.material), leaf.share);
        }
        return;
    }
    push_material_children(surface, node, material_at(surface.material), 1.0);
}

// The rays one Phong material spawns where `node.ray` hit. Objects sit in vacuum
// (GRAMMAR.md A4): a ray entering a surface (ray·N < 0) goes from index 1 into the
// material's, one leaving it back to 1.
fn push_material_children(surface: Surface, node: Pending, material: Material, share: f32) {
    let n = facing_normal(surface, node.ray);
    let d = node.ray.direction;
    let index_to = select(1.0, material.index_of_refraction, dot3(d, surface.normal) < 0.0);
    // Refraction first, so that reflection, which the reference adds first, is traced first.
    let refracted = refraction(d, n, node.index, index_to);
    if (refracted.w != 0.0) {
        push_ray(leaving(surface, -n, refracted.xyz), material.transparent, share, node, index_to);
    }
    let reflected = d - rounded3(2.0 * dot3(d, n) * n);
    push_ray(leaving(surface, n, reflected), material.reflective, share, node, node.index);
}

// The colour seen along a primary ray that hit `surface`: its own shading, then every ray of
// its tree (without TREE, the shading alone). The primary surface and every later one are
// shaded at the same call: shade() holds each light's shadow ray, and a second copy of it
// cost lavapipe's compiler a fifth more time on every kernel with a tree
// (docs/performance.md, "Compiles"). The sums are the same: the primary surface's
// throughput is 1 and the colour starts at 0.
fn color_of_tree(surface: Surface, ray: Ray) -> vec3<f32> {
    if (!TREE) {
        return shade(surface, ray);
    }
    var color = vec3<f32>(0.0);
    pending_len = 0u;
    var node = Pending(ray, vec3<f32>(1.0), 1.0, 1.0, 0u);
    var next = surface;
    loop {
        color += node.throughput * shade(next, node.ray);
        push_children(next, node);
        // The next waiting ray that hits a surface; those that miss see the background.
        loop {
            if (pending_len == 0u) {
                return color;
            }
            node = pop_pending();
            let hit = closest_hit(node.ray, 0.0);
            if (hit.t != NO_HIT) {
                next = surface_at(hit, node.ray);
                break;
            }
            color += node.throughput * P.background;
        }
        if (TEXTURES) {
            shading_secondary_ray = true;
        }
    }
    return color;
}

// What a pixel shows, shaded and not yet written; `beyond_reach` where a solid texture
// was blended beyond its reach on the way (shaders/texture.wgsl), or a reflected or
// refracted ray left its surface grazing it (spawned_grazing).
struct Shaded {
    hit: bool,
    color: vec3<f32>,
    normal: vec3<f32>,
    t: f32,
    beyond_reach: bool,
}

fn shade_pixel(ray: Ray, hit: Closest) -> Shaded {
    if (hit.t == NO_HIT) {
        return Shaded(false, P.background, vec3<f32>(0.0), 0.0, false);
    }
    let surface = surface_at(hit, ray);
    var color = vec3<f32>(0.0);
    if (TEXTURES) {
        beyond_texture_reach = false;
        shading_secondary_ray = false;
    }
    spawned_grazing = false;
    if (WANT_COLOR) {
        color = color_of_tree(surface, ray);
    }
    let beyond_reach = (TEXTURES && beyond_texture_reach) || (TREE && spawned_grazing);
    return Shaded(true, color, surface.normal, hit.t, beyond_reach);
}
