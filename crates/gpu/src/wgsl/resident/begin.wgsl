// Starts a step: whether geometry motion forces a rebuild in it (the host's track), and which
// worlds of a batch step in it (P_STEPPING: 1 stepping, 2 the step after its last, when only its
// check runs, 0 done): a world steps until its own number of steps or its first failure
// (K_FAILED + w, 0xffffffff while none). After an overflow (K_OVERFLOW) no world steps: the steps
// after it are discarded (the segment runs again, or ends at a chunk's start whose copies put
// the control words back), and lists that overflowed could only add other overflow codes.

@group(0) @binding(0) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(1) var<storage, read> forced: array<u32>;
@group(0) @binding(2) var<storage, read_write> params: array<f64>;


// One workgroup: its threads share the worlds, and all of them read the step before the first
// thread moves it on (one thread looped over every world of a batch).
const BEGIN_THREADS = 256;

@compute @workgroup_size(BEGIN_THREADS)
fn main(@builtin(local_invocation_index) lid: u32) {
    let s = atomicLoad(&ctrl[K_STEPS_BEGUN]);
    let worlds = atomicLoad(&ctrl[K_WORLDS]);
    let overflowed = atomicLoad(&ctrl[K_OVERFLOW]) != 0u;
    for (var w = lid; w < worlds; w += u32(BEGIN_THREADS)) {
        let steps = u32(params[P_LEN * w + P_STEPS]);
        var flag = 0.0lf;
        if (!overflowed && atomicLoad(&ctrl[K_FAILED + w]) == 0xffffffffu) {
            if (s < steps) {
                flag = 1.0lf;
            } else if (s == steps) {
                flag = 2.0lf;
            }
        }
        params[P_LEN * w + P_STEPPING] = flag;
    }
    workgroupBarrier();
    storageBarrier();
    if (lid == 0u) {
        atomicStore(&ctrl[K_REBUILD], forced[s]);
        atomicStore(&ctrl[K_STEPS_BEGUN], s + 1u);
    }
}
