// Starts a step: whether geometry motion forces a rebuild in it (the host's track), and which
// worlds of a batch step in it (P_STEPPING: 1 stepping, 2 the step after its last, when only its
// check runs, 0 done): a world steps until its own number of steps or its first failure
// (K_FAILED + w, 0xffffffff while none).

@group(0) @binding(0) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(1) var<storage, read> forced: array<u32>;
@group(0) @binding(2) var<storage, read_write> params: array<f64>;


@compute @workgroup_size(1)
fn main() {
    let s = atomicLoad(&ctrl[K_STEPS_BEGUN]);
    atomicStore(&ctrl[K_REBUILD], forced[s]);
    atomicStore(&ctrl[K_STEPS_BEGUN], s + 1u);
    let worlds = atomicLoad(&ctrl[K_WORLDS]);
    for (var w = 0u; w < worlds; w++) {
        let steps = u32(params[P_LEN * w + P_STEPS]);
        var flag = 0.0lf;
        if (atomicLoad(&ctrl[K_FAILED + w]) == 0xffffffffu) {
            if (s < steps) {
                flag = 1.0lf;
            } else if (s == steps) {
                flag = 2.0lf;
            }
        }
        params[P_LEN * w + P_STEPPING] = flag;
    }
}
