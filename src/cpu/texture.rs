//! The reference's solid textures (GRAMMAR.md A6, docs/SPEC.md §5): how much of a texture's
//! second material shows at a point of texture space, in f64. Perlin's improved noise is
//! written out here from his paper (Perlin 2002, "Improving Noise", SIGGRAPH), with his
//! published permutation, and shares nothing with the kernel.

use crate::scene::{Texture, TextureKind};
use glam::DVec3;

/// The weight of the texture's first material at `p` (texture space), in [0, 1]; the
/// second material gets `1 − weight`. The course's image of scene 6_15 settles the noise
/// and marble mappings (docs/SPEC.md §5): every pixel of its marble cubes and all but a
/// few of its noise cubes' match these.
pub fn first_material_weight(texture: &Texture, p: DVec3) -> f64 {
    match texture.kind {
        TextureKind::Checkerboard => 1.0 - checkerboard_parity(p),
        TextureKind::Noise => (0.5 + turbulence(p, texture.octaves)).clamp(0.0, 1.0),
        TextureKind::Marble => band(texture.frequency * p.x + texture.amplitude * turbulence(p, texture.octaves)),
        TextureKind::Wood => {
            let radius = (p.x * p.x + p.z * p.z).sqrt();
            band(texture.frequency * radius + texture.amplitude * turbulence(p, texture.octaves))
        }
    }
}

/// The unit checkerboard's parity, `floor x + floor y + floor z` modulo 2: 0 in the cell
/// `[0, 1)³` (the first material), 1 in the cells beside it (the handout's "odd" hint).
pub fn checkerboard_parity(p: DVec3) -> f64 {
    let sum = p.x.floor() + p.y.floor() + p.z.floor();
    // The floors are whole numbers, so rem_euclid is exact while the sum stays below 2⁵³,
    // and keeps the parity of negative sums.
    sum.rem_euclid(2.0)
}

/// `sin(phase)` from [−1, 1] mapped onto a weight in [0, 1]: `(1 + sin) / 2`.
fn band(phase: f64) -> f64 {
    (1.0 + phase.sin()) / 2.0
}

/// The handout's sum of octaves, `N(p) = Σ_{k < octaves} noise(2ᵏ p) / 2ᵏ`.
pub fn turbulence(p: DVec3, octaves: u32) -> f64 {
    (0..octaves).map(|k| (k as f64).exp2()).map(|scale| improved_noise(p * scale) / scale).sum()
}

/// Perlin's improved noise (Perlin 2002, "Improving Noise", and his reference Java code
/// `ImprovedNoise.java`): gradients picked by hashing the eight corners of the unit cell
/// through the permutation, dotted with the offset to each corner, blended with the
/// quintic `6t⁵ − 15t⁴ + 10t³`. Zero at every lattice point; about within [−1, 1].
pub fn improved_noise(p: DVec3) -> f64 {
    let cell = p.floor();
    let [x, y, z] = (p - cell).to_array();
    // The lattice repeats every 256 cells: the corner's coordinates modulo 256.
    let [xi, yi, zi] = cell.to_array().map(|c| c.rem_euclid(256.0) as usize);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = PERMUTATION[xi] as usize + yi;
    let (aa, ab) = (hash(a) + zi, hash(a + 1) + zi);
    let b = hash(xi + 1) + yi;
    let (ba, bb) = (hash(b) + zi, hash(b + 1) + zi);
    let near = lerp(
        v,
        lerp(u, grad(hash(aa), x, y, z), grad(hash(ba), x - 1.0, y, z)),
        lerp(u, grad(hash(ab), x, y - 1.0, z), grad(hash(bb), x - 1.0, y - 1.0, z)),
    );
    let far = lerp(
        v,
        lerp(u, grad(hash(aa + 1), x, y, z - 1.0), grad(hash(ba + 1), x - 1.0, y, z - 1.0)),
        lerp(u, grad(hash(ab + 1), x, y - 1.0, z - 1.0), grad(hash(bb + 1), x - 1.0, y - 1.0, z - 1.0)),
    );
    lerp(w, near, far)
}

/// Perlin's `p[i]`: the permutation doubled to 512 entries so that `p[i] + j` needs no wrap.
fn hash(i: usize) -> usize {
    PERMUTATION[i % 256] as usize
}

/// Perlin 2002's fade curve, `6t⁵ − 15t⁴ + 10t³`: zero first and second derivatives at 0 and 1.
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// Perlin 2002's twelve gradients (the cube's edge midpoints, four of them repeated to make
/// sixteen), chosen by the hash's low four bits, dotted with the offset `(x, y, z)`.
fn grad(hash: usize, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Perlin's published permutation of 0‥255 (Perlin 2002; his `ImprovedNoise.java`).
pub const PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37, 240,
    21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88,
    237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83,
    111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216,
    80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186,
    3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17,
    182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129,
    22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238,
    210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184,
    84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195,
    78, 66, 215, 61, 156, 180,
];
