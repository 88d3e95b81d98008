// A rebuild starts with empty buckets and reverse rows.

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> bucket_count: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> reverse_count: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> dims: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[K_REBUILD]) == 0u) {
        return;
    }
    let t = gid.x + gid.y * counts[C_ROW_WIDTH];
    if (t < dims[D_BUCKETS]) {
        atomicStore(&bucket_count[t], 0u);
    }
    if (t < dims[D_PARTICLES]) {
        atomicStore(&reverse_count[t], 0u);
    }
}
