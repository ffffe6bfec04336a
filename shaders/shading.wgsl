// uses: host, params, exact, ray, occluded, surface, texture
// Colour at a surface, lit directly (docs/SPEC.md §5): ambient, then per light Lambert's
// cosine law and the Blinn–Torrance specular lobe, each light first asked, with -shadows,
// whether anything blocks it.

// Light arriving at a point: from which direction (unit, toward the light), its colour
// there, and how far the light is (NO_HIT for a directional light).
struct Incoming {
    to_light: vec3<f32>,
    color: vec3<f32>,
    distance: f32,
}

// A point light's colour is divided by a0 + a1·d + a2·d² (the parser keeps the
// coefficients ≥ 0 and not all 0; at the light itself the divisor is kept from 0, as in the
// reference).
fn incoming(light: Light, p: vec3<f32>) -> Incoming {
    if (POINT_LIGHTS && light.is_point != 0u) {
        let offset = light.to_light_or_position - p;
        let d = length(offset);
        let a = light.attenuation;
        let divisor = max(a.x + a.y * d + a.z * d * d, 1.17549435e-38);
        return Incoming(offset / d, light.color / divisor, d);
    }
    return Incoming(light.to_light_or_position, light.color, NO_HIT);
}

// x^e for the specular lobe, x ≥ 0: pow is exp2(e·log2(x)) in WGSL, undefined at x = 0.
fn lobe_power(x: f32, e: f32) -> f32 {
    if (x <= 0.0) {
        return select(0.0, 1.0, e == 0.0);
    }
    return pow(x, e);
}

// What a surface with unit normal n (facing the viewer) reflects toward the viewer of the
// light `light`: max(N·L, 0)·light·diffuse, plus max(N·H, 0)^exponent·light·specular with
// the half vector H = normalise(L + V), cut where N·L ≤ 0 or, with SPECULAR_FIX,
// multiplied by N·L (the handout's optional fix; cpu::local).
fn local(material: Material, n: vec3<f32>, light: Incoming, to_viewer: vec3<f32>) -> vec3<f32> {
    let cos_light = dot3(light.to_light, n);
    let diffuse = max(cos_light, 0.0) * light.color * material.diffuse;
    if (!SPECULAR || all(material.specular == vec3<f32>(0.0)) || cos_light <= 0.0) {
        return diffuse;
    }
    let sum = light.to_light + to_viewer;
    if (all(sum == vec3<f32>(0.0))) {
        return diffuse;
    }
    var lobe = lobe_power(max(dot(n, normalize(sum)), 0.0), material.exponent);
    if (SPECULAR_FIX) {
        lobe *= cos_light;
    }
    return diffuse + lobe * light.color * material.specular;
}

// Whether something lies between the surface and `light`, arriving as `arriving`: a
// shadow ray from the point, moved off the surface on the lit side, up to the light. A
// shadow ray into the solid it starts on is blocked where it leaves it, unless the light
// is inside (solid_exit_t: the moved ray may start beyond a grazing chord).
fn in_shadow(surface: Surface, n: vec3<f32>, light: Light, arriving: Incoming) -> bool {
    let origin = spawn_origin(surface, n, arriving.to_light);
    let point_light = POINT_LIGHTS && light.is_point != 0u;
    if (HAS_SPHERES || HAS_ELLIPSOIDS) {
        let leaves_at = solid_exit_t(surface, arriving.to_light);
        let light_distance = select(NO_HIT, distance(light.to_light_or_position, surface.point), point_light);
        if (leaves_at > 0.0 && leaves_at < light_distance) {
            return true;
        }
    }
    let tmax = select(NO_HIT, distance(light.to_light_or_position, origin), point_light);
    return occluded(Ray(origin, arriving.to_light), 0.0, tmax);
}

// A back face is black unless SHADE_BACK, which shades it with the flipped normal, as the
// course's -shade_back does.
fn is_black(surface: Surface, ray: Ray) -> bool {
    return !shades_back() && dot3(ray.direction, surface.normal) > 0.0;
}

// The normal turned toward the viewer.
fn facing_normal(surface: Surface, ray: Ray) -> vec3<f32> {
    return select(surface.normal, -surface.normal, dot3(ray.direction, surface.normal) > 0.0);
}

// Ambient plus each light, seen along `ray` (unit direction); a solid texture's blend of
// its materials' colours.
fn shade(surface: Surface, ray: Ray) -> vec3<f32> {
    if (is_black(surface, ray)) {
        return vec3<f32>(0.0);
    }
    let n = facing_normal(surface, ray);
    if (TEXTURES && textures[surface.material].kind != 0u) {
        return shade_blend(surface, n, ray);
    }
    return shade_phong(material_at(surface.material), surface, n, ray);
}

// The scene's lights where they are at most LIGHT_CACHE, and its material where it has one,
// loaded once per invocation (load_shading_data): an invocation of main_bins shades PACKET
// pixels, a ray tree many surfaces, and each would load them again, lane by lane on
// lavapipe even though every lane reads the same address (docs/lavapipe.md). Otherwise
// each use loads its own.
const LIGHT_CACHE: u32 = 4u;
var<private> cached_lights: array<Light, LIGHT_CACHE>;
var<private> only_material: Material;

// Called by the entry points before they shade. Only colour is shaded: a kernel for
// normals or depth alone loads nothing.
fn load_shading_data() {
    if (!WANT_COLOR) {
        return;
    }
    if (light_count() <= LIGHT_CACHE) {
        for (var k = 0u; k < light_count(); k++) {
            cached_lights[k] = lights[k];
        }
    }
    if (ONE_MATERIAL) {
        only_material = materials[0];
    }
}

fn light_at(k: u32) -> Light {
    if (light_count() <= LIGHT_CACHE) {
        return cached_lights[k];
    }
    return lights[k];
}

fn material_at(m: u32) -> Material {
    if (ONE_MATERIAL) {
        return only_material;
    }
    return materials[m];
}

// One Phong material's colour at the surface, n facing the viewer.
fn shade_phong(material: Material, surface: Surface, n: vec3<f32>, ray: Ray) -> vec3<f32> {
    var color = P.ambient * material.diffuse;
    for (var k = 0u; k < light_count(); k++) {
        let light = light_at(k);
        let arriving = incoming(light, surface.point);
        // A light behind the surface adds nothing, so it needs no shadow ray.
        if (SHADOWS && dot3(arriving.to_light, n) > 0.0 && in_shadow(surface, n, light, arriving)) {
            continue;
        }
        color += local(material, n, arriving, -ray.direction);
    }
    return color;
}

// The materials a texture blends, waiting with their shares: depth first, at most one
// sibling waits per level of nesting, so BLEND_STACK (the parser's nesting limit + 1)
// slots hold them.
var<private> blend_material: array<u32, BLEND_STACK>;
var<private> blend_share: array<f32, BLEND_STACK>;
var<private> blend_len: u32;

// A Phong material a texture's blend reaches and its share there, the product of the
// shares on its way; NO_LEAF once the blend has no more.
struct Leaf {
    material: u32,
    share: f32,
}

const NO_LEAF: u32 = 0xffffffffu;

fn start_blend(material: u32) {
    blend_material[0] = material;
    blend_share[0] = 1.0;
    blend_len = 1u;
}

// The blend's next Phong material at the camera-relative point p, met by a ray at `cosine`
// to the surface, as the reference walks it (cpu::Reference::shade_material): the first
// material before the second, and a material with no share not at all.
fn next_leaf(p: vec3<f32>, cosine: f32) -> Leaf {
    while (blend_len > 0u) {
        blend_len -= 1u;
        let m = blend_material[blend_len];
        let share = blend_share[blend_len];
        let t = textures[m];
        if (t.kind == 0u) {
            return Leaf(m, share);
        }
        let first = first_material_share(t, p, cosine);
        if (first < 1.0) {
            blend_material[blend_len] = t.second;
            blend_share[blend_len] = share * (1.0 - first);
            blend_len += 1u;
        }
        if (first > 0.0) {
            blend_material[blend_len] = t.first;
            blend_share[blend_len] = share * first;
            blend_len += 1u;
        }
    }
    return Leaf(NO_LEAF, 0.0);
}

// |cos| of the angle at which `ray` meets the surface: the hit's error along the surface
// grows as it falls (check_reach).
fn cosine_to(surface: Surface, ray: Ray) -> f32 {
    return abs(dot3(surface.normal, ray.direction));
}

// The texture at the surface's material as the reference blends it: each Phong material
// it reaches, shaded and weighted by its share.
fn shade_blend(surface: Surface, n: vec3<f32>, ray: Ray) -> vec3<f32> {
    var color = vec3<f32>(0.0);
    start_blend(surface.material);
    let cosine = cosine_to(surface, ray);
    loop {
        let leaf = next_leaf(surface.point, cosine);
        if (leaf.material == NO_LEAF) {
            break;
        }
        color += leaf.share * shade_phong(material_at(leaf.material), surface, n, ray);
    }
    return color;
}
