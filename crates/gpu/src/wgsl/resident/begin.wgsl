// Starts a step: whether geometry motion forces a rebuild in it (the host's track), and which
// worlds of a batch step in it (params 17: 1 stepping, 2 the step after its last, when only its
// check runs, 0 done): a world steps until its own number of steps or its first failure.
//
// ctrl 5: worlds; ctrl 8 + w: world w's first failed step (0xffffffff: none).

@group(0) @binding(0) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(1) var<storage, read> forced: array<u32>;
@group(0) @binding(2) var<storage, read_write> params: array<f64>;


@compute @workgroup_size(1)
fn main() {
    let s = atomicLoad(&ctrl[0]);
    atomicStore(&ctrl[1], forced[s]);
    atomicStore(&ctrl[0], s + 1u);
    let worlds = atomicLoad(&ctrl[5]);
    for (var w = 0u; w < worlds; w++) {
        let steps = u32(params[PARAMS * w + P_STEPS]);
        var flag = 0.0lf;
        if (atomicLoad(&ctrl[8u + w]) == 0xffffffffu) {
            if (s < steps) {
                flag = 1.0lf;
            } else if (s == steps) {
                flag = 2.0lf;
            }
        }
        params[PARAMS * w + P_STEPPING] = flag;
    }
}
