// The pair histories in two halves (`history_even` and `history_odd`, each bound in parts with
// their accessors by `kernels::split_lists`, and `ctrl` bound): step s reads the histories
// before it from half s % 2 and writes those after it to the other half, so that both particles
// of a pair evaluate it from the same history in one launch while the pair's first particle
// writes the new one (particle_forces.wgsl). The lists' first build, before step 0, works in
// half 0, as step 0 does. A world stops writing when it stops stepping, so the host reads a
// world's histories from half (its steps done) % 2.

// The half that holds the histories before the current step.
fn history_half() -> u32 {
    let begun = atomicLoad(&ctrl[K_STEPS_BEGUN]);
    if (begun == 0u) {
        return 0u;
    }
    return (begun - 1u) & 1u;
}

fn half_get(half: u32, k: u32) -> f64 {
    if (half == 0u) {
        return history_even_get(k);
    }
    return history_odd_get(k);
}

fn half_put(half: u32, k: u32, v: f64) {
    if (half == 0u) {
        history_even_put(k, v);
    } else {
        history_odd_put(k, v);
    }
}

fn half_get3(half: u32, k: u32) -> vec3<f64> {
    return vec3<f64>(half_get(half, k), half_get(half, k + 1u), half_get(half, k + 2u));
}

fn half_put3(half: u32, k: u32, v: vec3<f64>) {
    for (var d = 0; d < 3; d++) {
        half_put(half, k + u32(d), v[d]);
    }
}
