// Hertz-Mindlin between candidate pairs (CpuBackend::pair_forces; the pair in pair_contact.wgsl,
// the law in contact.wgsl).
// One thread per pair; each writes its own history and output slot.
//
// pair_ij: rows of IJ_LEN; history: rows of H_LEN; output: rows of PO_LEN; table: rows of T_LEN
// per material pair; ints: blocks of N (I_). layout.rs says what each place holds.

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> ints: array<u32>;
@group(0) @binding(3) var<storage, read> pair_ij: array<u32>;
@group(0) @binding(4) var<storage, read> table: array<f64>;
@group(0) @binding(5) var<storage, read> params: array<f64>;
@group(0) @binding(6) var<storage, read> counts: array<u32>;

// After these: `history` and `output`, the pair slots' histories and outputs
// (`kernels::split_lists`; this kernel has no variant in parts: the stage path binds each whole).

fn clear_output(q: u32) {
    for (var k = 0u; k < PO_LEN; k++) {
        output_put(PO_LEN * q + k, 0.0lf);
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_index(gid);
    if (q >= counts[C_PAIRS]) {
        return;
    }
    let n = counts[C_PARTICLES];
    let i = pair_ij[IJ_LEN * q + IJ_I];
    if (i == NO_BODY) {
        // An empty slot of a fixed-capacity row (the resident steps).
        return;
    }
    let j = pair_ij[IJ_LEN * q + IJ_J];
    set_world(i);
    if (!stepping()) {
        return;
    }
    if (same_clump(i, j)) {
        clear_output(q);
        return;
    }
    let g = pair_gap(i, j);
    if (!g.touching) {
        for (var k = 0u; k < H_LEN; k++) {
            history_put(H_LEN * q + k, 0.0lf);
        }
        clear_output(q);
        return;
    }
    let c = pair_law(i, j, g, hist3(H_LEN * q + H_TANGENTIAL), hist3(H_LEN * q + H_ROLLING));
    put_hist3(H_LEN * q + H_TANGENTIAL, c.shear);
    put_hist3(H_LEN * q + H_ROLLING, c.moment);
    let l = pair_loads(g, c);
    let o = PO_LEN * q;
    put_out3(o + PO_FORCE, l.force);
    put_out3(o + PO_TORQUE_I, l.torque_i);
    put_out3(o + PO_TORQUE_J, l.torque_j);
    output_put(o + PO_ROLLING_I, l.rolling_i);
    output_put(o + PO_ROLLING_J, l.rolling_j);
}
