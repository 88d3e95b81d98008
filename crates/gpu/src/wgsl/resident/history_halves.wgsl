// The pair histories in two halves (`history_even` and `history_odd`, bound read_write by the
// kernel with `ctrl`): step s reads the histories before it from half s % 2 and writes those
// after it to the other half, so that both particles of a pair evaluate it from the same history
// in one launch while the pair's first particle writes the new one (particle_forces.wgsl). The
// lists' first build, before step 0, works in half 0, as step 0 does. A world stops writing when
// it stops stepping, so the host reads a world's histories from half (its steps done) % 2.

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
        return history_even[k];
    }
    return history_odd[k];
}

fn half_put(half: u32, k: u32, v: f64) {
    if (half == 0u) {
        history_even[k] = v;
    } else {
        history_odd[k] = v;
    }
}

fn half_get3(half: u32, k: u32) -> vec3<f64> {
    return vec3<f64>(half_get(half, k), half_get(half, k + 1u), half_get(half, k + 2u));
}

fn half_put3(half: u32, k: u32, v: vec3<f64>) {
    if (half == 0u) {
        history_even[k] = v.x;
        history_even[k + 1u] = v.y;
        history_even[k + 2u] = v.z;
    } else {
        history_odd[k] = v.x;
        history_odd[k + 1u] = v.y;
        history_odd[k + 2u] = v.z;
    }
}
