// The new rows become the current ones (after every kernel of the rebuild has read the old).

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read> dims: array<u32>;
@group(0) @binding(3) var<storage, read_write> pair_ij: array<u32>;
@group(0) @binding(4) var<storage, read_write> pair_history: array<f64>;
@group(0) @binding(5) var<storage, read> new_ij: array<u32>;
@group(0) @binding(6) var<storage, read> new_pair_history: array<f64>;
@group(0) @binding(7) var<storage, read_write> cands: array<u32>;
@group(0) @binding(8) var<storage, read_write> wall_history: array<f64>;
@group(0) @binding(9) var<storage, read> new_cands: array<u32>;
@group(0) @binding(10) var<storage, read> new_wall_history: array<f64>;
@group(0) @binding(11) var<storage, read> props: array<f64>;
@group(0) @binding(12) var<storage, read> params: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[1]) == 0u) {
        return;
    }
    let i = gid.x + gid.y * counts[4];
    if (i >= dims[0]) {
        return;
    }
    if (i == 0u) {
        atomicAdd(&ctrl[4], 1u);
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    if (params[PARAMS * u32(props[4u * dims[0] + i]) + P_STEPPING] != 1.0lf) {
        return;
    }
    let cap = dims[1];
    for (var q = i * cap; q < (i + 1u) * cap; q++) {
        pair_ij[2u * q] = new_ij[2u * q];
        pair_ij[2u * q + 1u] = new_ij[2u * q + 1u];
        for (var h = 0u; h < 6u; h++) {
            pair_history[6u * q + h] = new_pair_history[6u * q + h];
        }
    }
    let wcap = dims[2];
    for (var c = i * wcap; c < (i + 1u) * wcap; c++) {
        cands[2u * c] = new_cands[2u * c];
        cands[2u * c + 1u] = new_cands[2u * c + 1u];
        for (var h = 0u; h < 6u; h++) {
            wall_history[6u * c + h] = new_wall_history[6u * c + h];
        }
    }
}
