// uses: host, params, exact
// Solid textures (docs/SPEC.md §5, GRAMMAR.md A6), in f32 where the host's precision check
// (gpu::precision, "textures") found the texture coordinates small enough: the share of a
// texture's first material at a texture-space point, and Perlin's improved noise (Perlin
// 2002, "Improving Noise"; his reference code ImprovedNoise.java), as cpu::texture computes
// them in f64.

// Perlin's published permutation of 0..255, from its buffer (gpu::layout::PERLIN_PERMUTATION):
// lavapipe took minutes to compile a constant array indexed at run time.
fn perm(i: u32) -> u32 {
    return permutation[i & 255u];
}

// 6t⁵ − 15t⁴ + 10t³: zero first and second derivatives at 0 and 1.
fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// One of the twelve edge-midpoint gradients (four repeated), picked by the hash's low four
// bits, dotted with the offset (x, y, z) to its corner.
fn grad(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15u;
    let u = select(y, x, h < 8u);
    let v = select(select(z, x, h == 12u || h == 14u), y, h < 4u);
    return select(-u, u, (h & 1u) == 0u) + select(-v, v, (h & 2u) == 0u);
}

fn improved_noise(p: vec3<f32>) -> f32 {
    let cell = floor(p);
    let f = p - cell;
    // The corner modulo 256; two's complement keeps negative cells' residues.
    let c = vec3<u32>(vec3<i32>(cell) & vec3<i32>(255));
    let u = fade(f.x);
    let v = fade(f.y);
    let w = fade(f.z);
    let a = perm(c.x) + c.y;
    let aa = perm(a) + c.z;
    let ab = perm(a + 1u) + c.z;
    let b = perm(c.x + 1u) + c.y;
    let ba = perm(b) + c.z;
    let bb = perm(b + 1u) + c.z;
    let near = mix(
        mix(grad(perm(aa), f.x, f.y, f.z), grad(perm(ba), f.x - 1.0, f.y, f.z), u),
        mix(grad(perm(ab), f.x, f.y - 1.0, f.z), grad(perm(bb), f.x - 1.0, f.y - 1.0, f.z), u),
        v,
    );
    let far = mix(
        mix(grad(perm(aa + 1u), f.x, f.y, f.z - 1.0), grad(perm(ba + 1u), f.x - 1.0, f.y, f.z - 1.0), u),
        mix(grad(perm(ab + 1u), f.x, f.y - 1.0, f.z - 1.0), grad(perm(bb + 1u), f.x - 1.0, f.y - 1.0, f.z - 1.0), u),
        v,
    );
    return mix(near, far, w);
}

// The handout's N(q) = Σ_{k < octaves} noise(2ᵏ q) / 2ᵏ.
fn turbulence(q: vec3<f32>, octaves: u32) -> f32 {
    var sum = 0.0;
    var scale = 1.0;
    for (var k = 0u; k < octaves; k++) {
        sum += improved_noise(q * scale) / scale;
        scale *= 2.0;
    }
    return sum;
}

// (1 + sin(phase)) / 2: a band of Marble or Wood as a share in [0, 1].
fn band(phase: f32) -> f32 {
    return (1.0 + sin(phase)) / 2.0;
}

// Set where a texture was blended at a point beyond its reach (gpu::texture_range): the
// pixel is marked for the host, which renders it with the reference.
var<private> beyond_texture_reach: bool;
// Whether the ray being shaded was reflected or refracted (shaders/tree.wgsl).
var<private> shading_secondary_ray: bool;

// Q = max_i Σ_j |M_ij|·|p_j| + |t_i|, the magnitude that bounds the rounding of q = M·p
// (gpu::texture_range's contract), compared with what the texture tolerates. A bounded
// primitive's points the host checks before the render; a plane's reach the horizon, so
// every hit is checked here too. The hit itself is off by a few ulps of its magnitudes,
// which a ray meeting the surface at `cosine` stretches along it by 1/cosine: at a grazing
// ray the reach shrinks by that factor (a wood-grained plane seen 7 500 units away at a
// cosine of 10⁻³ was 13 levels off otherwise). A reflected or refracted ray's hit carries
// the errors of its whole path, which a curved mirror or glass magnifies: a smooth
// texture's share moves with them continuously, but the checkerboard's parity flips, so
// the kernel leaves a checkerboard seen that way to the reference (scene6_14 at 100²: 12 of
// 10 000 pixels more than one level off otherwise).
fn check_reach(t: Texture, p: vec3<f32>, cosine: f32) {
    let a = abs(p);
    let q = max(max(dot3(abs(t.row0.xyz), a) + abs(t.row0.w), dot3(abs(t.row1.xyz), a) + abs(t.row1.w)),
                dot3(abs(t.row2.xyz), a) + abs(t.row2.w));
    // `!(q <= ...)`: a NaN coordinate is beyond reach too.
    if (!(q <= t.reach * cosine) || (shading_secondary_ray && t.kind == 1u)) {
        beyond_texture_reach = true;
    }
}

// The share of the texture's first material at the camera-relative point p, met by a ray
// at `cosine` to the surface.
fn first_material_share(t: Texture, p: vec3<f32>, cosine: f32) -> f32 {
    check_reach(t, p, cosine);
    let h = vec4<f32>(p, 1.0);
    // Rounded products (shaders/exact.wgsl): which checkerboard cell a point lies in is a
    // decision, the same on every driver.
    let q = vec3<f32>(dot4(t.row0, h), dot4(t.row1, h), dot4(t.row2, h));
    switch t.kind {
        case 1u: {
            let cell = floor(q);
            // Even cells (the one at the origin among them) show the first material.
            return select(0.0, 1.0, (i32(cell.x + cell.y + cell.z) & 1) == 0);
        }
        case 2u: {
            return clamp(0.5 + turbulence(q, t.octaves), 0.0, 1.0);
        }
        case 3u: {
            return band(t.frequency * q.x + t.amplitude * turbulence(q, t.octaves));
        }
        default: {
            return band(t.frequency * length(q.xz) + t.amplitude * turbulence(q, t.octaves));
        }
    }
}
