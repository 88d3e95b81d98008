// Starts a step: whether geometry motion forces a rebuild in it (the host's track).

@group(0) @binding(0) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(1) var<storage, read> forced: array<u32>;

@compute @workgroup_size(1)
fn main() {
    let s = atomicLoad(&ctrl[0]);
    atomicStore(&ctrl[1], forced[s]);
    atomicStore(&ctrl[0], s + 1u);
}
