// After the drift: a rebuild when a particle has moved half the skin since the last one; the
// first step in which a particle of a world is not finite or has left the domain (K_FAILED + w); a
// particle that touched more walls than the wall kernel keeps in the step before. Worlds that are
// done are skipped; one whose steps just ended is checked once more (its last kick).

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read> moved: array<f64>;
@group(0) @binding(3) var<storage, read> outside: array<u32>;
@group(0) @binding(4) var<storage, read> status: array<u32>;
@group(0) @binding(5) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read> search: array<f64>;
@group(0) @binding(7) var<storage, read> props: array<f64>;
@group(0) @binding(8) var<storage, read> params: array<f64>;


fn finite(v: vec3<f64>) -> bool {
    let s = v.x + v.y + v.z;
    return s == s && abs(s) < 1.0e300lf;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[C_PARTICLES];
    if (i >= n) {
        return;
    }
    // Worlds still stepping, and those whose steps just ended.
    set_world(i);
    if (param(P_STEPPING) == 0.0lf) {
        return;
    }
    if (moved[i] > search[SE_HALF_SKIN_SQUARED]) {
        atomicOr(&ctrl[K_REBUILD], 1u);
    }
    if (outside[i] != 0u || !finite(position(i)) || !finite(velocity(i))) {
        // The step in which it failed; found by the check after a world's last step (its
        // steps' count), the step after it, in which the CPU would find it.
        let w = u32(props[PR_WORLD * n + i]);
        atomicMin(&ctrl[K_FAILED + w], atomicLoad(&ctrl[K_STEPS_BEGUN]) - 1u);
    }
    if (status[i] != 0u) {
        atomicMax(&ctrl[K_OVERFLOW], OV_WALLS_KEPT);
    }
}
