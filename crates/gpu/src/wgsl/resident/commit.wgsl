// The new rows become the current ones (after every kernel of the rebuild has read the old).

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read> dims: array<u32>;
@group(0) @binding(3) var<storage, read_write> pair_ij: array<u32>;
@group(0) @binding(4) var<storage, read> new_ij: array<u32>;
@group(0) @binding(5) var<storage, read_write> cands: array<u32>;
@group(0) @binding(6) var<storage, read> new_cands: array<u32>;
@group(0) @binding(7) var<storage, read> props: array<f64>;
@group(0) @binding(8) var<storage, read> params: array<f64>;

// After these: the pair histories' halves (the current half takes the new ones,
// history_halves.wgsl), the new pair histories, the wall histories and the new wall histories,
// each in parts (`kernels::split_lists`).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[K_REBUILD]) == 0u) {
        return;
    }
    let i = gid.x + gid.y * counts[C_ROW_WIDTH];
    let n = dims[D_PARTICLES];
    if (i >= n) {
        return;
    }
    if (i == 0u) {
        atomicAdd(&ctrl[K_REBUILDS], 1u);
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    if (params[P_LEN * u32(props[PR_WORLD * n + i]) + P_STEPPING] != 1.0lf) {
        return;
    }
    let cap = dims[D_PAIR_CAPACITY];
    let half = history_half();
    for (var q = i * cap; q < (i + 1u) * cap; q++) {
        for (var k = 0u; k < IJ_LEN; k++) {
            pair_ij[IJ_LEN * q + k] = new_ij[IJ_LEN * q + k];
        }
        for (var h = 0u; h < H_LEN; h++) {
            half_put(half, H_LEN * q + h, new_pair_history_get(H_LEN * q + h));
        }
    }
    let wcap = dims[D_WALL_CAPACITY];
    for (var c = i * wcap; c < (i + 1u) * wcap; c++) {
        for (var k = 0u; k < WC_LEN; k++) {
            cands[WC_LEN * c + k] = new_cands[WC_LEN * c + k];
        }
        for (var h = 0u; h < H_LEN; h++) {
            wall_history_put(H_LEN * c + h, new_wall_history_get(H_LEN * c + h));
        }
    }
}
