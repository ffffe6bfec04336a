//! Floats as unsigned integers in the order `f32::total_cmp` gives them: what the bins sort
//! their items by, and what the window's depth view compares depths by on the device
//! (`shaders/present/enlarge.wgsl` has the same `ordered_key`).

/// The key that orders `value` among floats: the sign bit flipped for positive numbers,
/// every bit for negative ones.
pub fn ordered_key(value: f32) -> u32 {
    let bits = value.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 1 << 31
    }
}

/// The float an [`ordered_key`] stands for (the depth view's bounds: not in a browser, which
/// has no window of ours).
#[cfg_attr(target_arch = "wasm32", allow(dead_code))]
pub fn from_ordered_key(key: u32) -> f32 {
    f32::from_bits(if key >> 31 == 1 { key & !(1 << 31) } else { !key })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_order_floats_as_total_cmp_does_and_give_them_back() {
        let values =
            [f32::NEG_INFINITY, -3.5, -f32::MIN_POSITIVE / 2.0, -0.0, 0.0, 1e-40, 1.0, f32::MAX, f32::INFINITY];
        for pair in values.windows(2) {
            assert!(ordered_key(pair[0]) < ordered_key(pair[1]), "{} before {}", pair[0], pair[1]);
        }
        for v in values {
            assert_eq!(from_ordered_key(ordered_key(v)).to_bits(), v.to_bits());
        }
    }
}
