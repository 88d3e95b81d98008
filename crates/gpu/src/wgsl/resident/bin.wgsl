// Every particle into its cell's bucket (the order within a bucket does not matter: rows are
// sorted when they are built).

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> bucket_count: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> bucket_items: array<u32>;
@group(0) @binding(5) var<storage, read> dims: array<u32>;
@group(0) @binding(6) var<storage, read> search: array<f64>;
@group(0) @binding(7) var<storage, read> props: array<f64>;
@group(0) @binding(8) var<storage, read> params: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[1]) == 0u) {
        return;
    }
    let i = gid.x + gid.y * counts[4];
    if (i >= dims[0]) {
        return;
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    if (params[PARAMS * u32(props[4u * dims[0] + i]) + P_STEPPING] != 1.0lf) {
        return;
    }
    let x = vec3<f64>(state[3u * i], state[3u * i + 1u], state[3u * i + 2u]);
    let b = bucket_of(cell_of(x, search[0]), u32(props[4u * dims[0] + i]), dims[3]);
    let slot = atomicAdd(&bucket_count[b], 1u);
    if (slot < dims[4]) {
        bucket_items[b * dims[4] + slot] = i;
    } else {
        atomicMax(&ctrl[3], 1u);
    }
}
