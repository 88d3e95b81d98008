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
    if (atomicLoad(&ctrl[K_REBUILD]) == 0u) {
        return;
    }
    let i = thread_index(gid);
    let n = dims[D_PARTICLES];
    if (i >= n) {
        return;
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    set_world(i);
    if (!stepping()) {
        return;
    }
    let world = u32(props[PR_WORLD * n + i]);
    let b = bucket_of(cell_of(position(i), search[SE_INV_CELL]), world, dims[D_BUCKETS]);
    let slot = atomicAdd(&bucket_count[b], 1u);
    if (slot < dims[D_BUCKET_CAPACITY]) {
        bucket_items[b * dims[D_BUCKET_CAPACITY] + slot] = i;
    } else {
        atomicMax(&ctrl[K_OVERFLOW], OV_BUCKET);
    }
}
