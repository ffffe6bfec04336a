// Colour at a surface (docs/SPEC.md §5).

// Ambient plus Lambert per directional light; a back-facing hit is black unless SHADE_BACK,
// which shades it with the flipped normal, as the course's -shade_back does.
fn shade(surface: Surface, ray: Ray) -> vec3<f32> {
    var n = surface.normal;
    if (dot(ray.direction, n) > 0.0) {
        if (!SHADE_BACK) {
            return vec3<f32>(0.0);
        }
        n = -n;
    }
    let diffuse = materials[surface.material].diffuse;
    var color = P.ambient * diffuse;
    for (var k = 0u; k < NUM_LIGHTS; k++) {
        let light = lights[k];
        color += max(dot(light.to_light, n), 0.0) * light.color * diffuse;
    }
    return color;
}
