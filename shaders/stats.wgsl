// uses: host, params
// The course's statistics (-stats; docs/SPEC.md §7), counted only where STATS: with it
// false every call of count folds away and no counter is touched, so a render without
// -stats runs the kernel it ran before. An invocation counts in private registers and adds
// its sums to the `counters` buffer once, at its end (flush_counts): one atomic per
// counter and invocation, never one per test.
//
// `counters` holds STATS_SLOTS slots of STATS_WORDS words: for each counter (non-shadow
// rays, shadow rays, ray–primitive tests, grid cells entered) a low and a high word. An
// invocation adds into the slot its pixel picks, so that neighbouring invocations contend
// on different words; the host sums the slots (gpu::layout::sum_counters).
//
// No count wraps: an invocation's own count is added into slot 0 and restarted whenever
// it reaches 2³¹ (count; no pixel of the course comes near: lavapipe stops an invocation
// after 65 535 loop iterations in all), and the sum over invocations carries into the
// high word whenever the low word wraps (add_count), so a slot counts to 2⁶⁴.

// This invocation's counts, in the host's order (render::RayStats, gpu::layout::
// sum_counters): the indices below.
var<private> counted: array<u32, 4>;
const COUNT_RAYS: u32 = 0u;
const COUNT_SHADOW_RAYS: u32 = 1u;
const COUNT_TESTS: u32 = 2u;
const COUNT_CELLS: u32 = 3u;

fn count(what: u32) {
    if (STATS) {
        counted[what] += 1u;
        if (counted[what] == 0x80000000u) {
            add_count(2u * what, counted[what]);
            counted[what] = 0u;
        }
    }
}

// Adds v to the 64-bit count whose low word is counters[word]: atomicAdd returns the value
// it replaced, so exactly the addition that wraps the low word carries one into the high.
fn add_count(word: u32, v: u32) {
    if (v == 0u) {
        return;
    }
    let before = atomicAdd(&counters[word], v);
    if (before > 0xffffffffu - v) {
        atomicAdd(&counters[word + 1u], 1u);
    }
}

// Adds this invocation's counts into slot `key` % STATS_SLOTS.
fn flush_counts(key: u32) {
    if (!STATS) {
        return;
    }
    let base = (key % STATS_SLOTS) * STATS_WORDS;
    for (var k = 0u; k < 4u; k++) {
        add_count(base + 2u * k, counted[k]);
    }
}

// Which slot of `counters` an invocation adds into: neighbours in a workgroup take
// different ones.
fn stats_slot(id: vec3<u32>) -> u32 {
    return id.x + WORKGROUP * id.y;
}
