// After `check`: the workgroups of the rebuild kernels in this step, as indirect dispatch
// arguments (x, y, z each): all of them when a rebuild is due, none when not, so that a step
// without a rebuild starts no thread of them (they used to start every thread to return at once).
//
// full (u32): each rebuild launch's x, y, z; args: what the dispatches read.

@group(0) @binding(0) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(1) var<storage, read> full: array<u32>;
@group(0) @binding(2) var<storage, read_write> args: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= arrayLength(&full)) {
        return;
    }
    var v = 0u;
    if (atomicLoad(&ctrl[K_REBUILD]) != 0u) {
        v = full[k];
    }
    args[k] = v;
}
