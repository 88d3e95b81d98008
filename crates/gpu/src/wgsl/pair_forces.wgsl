// Hertz-Mindlin between candidate pairs (CpuBackend::pair_forces; the law is in contact.wgsl).
// One thread per pair; each writes its own history and output slot.
//
// pair_ij: rows of IJ_LEN; history: rows of H_LEN; output: rows of PO_LEN; table: rows of T_LEN
// per material pair; ints: blocks of N (I_). layout.rs says what each place holds.

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> ints: array<u32>;
@group(0) @binding(3) var<storage, read> pair_ij: array<u32>;
@group(0) @binding(4) var<storage, read_write> history: array<f64>;
@group(0) @binding(5) var<storage, read_write> output: array<f64>;
@group(0) @binding(6) var<storage, read> table: array<f64>;
@group(0) @binding(7) var<storage, read> params: array<f64>;
@group(0) @binding(8) var<storage, read> counts: array<u32>;

fn clear_output(q: u32) {
    for (var k = 0u; k < PO_LEN; k++) {
        output[PO_LEN * q + k] = 0.0lf;
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
    let body_i = ints[I_BODY * n + i];
    if (param(P_CLUMPS) != 0.0lf && body_i == ints[I_BODY * n + j] && body_i != NO_BODY) {
        // Members of one clump overlap by design.
        clear_output(q);
        return;
    }
    let delta = position(i) - position(j);
    let ri = props[PR_RADIUS * n + i];
    let rj = props[PR_RADIUS * n + j];
    let sum = ri + rj;
    let dist2 = len2(delta);
    let r_eff = ri * rj / sum;
    // The row of the pair's materials in the world's table (P_MATERIALS a side).
    let mi = ints[I_MATERIAL * n + i];
    let mj = ints[I_MATERIAL * n + j];
    let t = u32(param(P_TABLE)) + T_LEN * (mi * u32(param(P_MATERIALS)) + mj);
    // A cohesive (JKR) pair attracts until the gap reaches the law's cut-off.
    var reach = sum;
    if (param(P_COHESIVE) != 0.0lf) {
        reach = sum - cutoff_of(t, r_eff);
    }
    if (dist2 >= reach * reach) {
        for (var k = 0u; k < H_LEN; k++) {
            history[H_LEN * q + k] = 0.0lf;
        }
        clear_output(q);
        return;
    }
    let dist = sqrt(dist2);
    // As the CPU: one division, then products.
    let nrm = delta * (1.0lf / dist);
    let d = sum - dist;
    let ci = ri - 0.5lf * d;
    let cj = rj - 0.5lf * d;
    let wi = angular_velocity(i);
    let wj = angular_velocity(j);
    let m_eff = 1.0lf / (props[PR_INV_MASS * n + i] + props[PR_INV_MASS * n + j]);
    let v_rel = velocity(i) - velocity(j);
    let ai = props[PR_MASS * n + i] * ri * ri;
    let aj = props[PR_MASS * n + j] * rj * rj;
    let c = hertz_mindlin(
        t,
        nrm,
        d,
        r_eff,
        m_eff,
        v_rel,
        ci * wi + cj * wj,
        wi - wj,
        1.4lf * ai * aj / (ai + aj),
        hist3(H_LEN * q + H_TANGENTIAL),
        hist3(H_LEN * q + H_ROLLING),
    );
    put_hist3(H_LEN * q + H_TANGENTIAL, c.shear);
    put_hist3(H_LEN * q + H_ROLLING, c.moment);
    let nxf = cross3(nrm, c.tangential);
    let o = PO_LEN * q;
    put_out3(o + PO_FORCE, c.force);
    put_out3(o + PO_TORQUE_I, -ci * nxf + c.rolling_torque);
    put_out3(o + PO_TORQUE_J, -cj * nxf - c.rolling_torque);
    output[o + PO_ROLLING_I] = c.rolling_resistance * ci;
    output[o + PO_ROLLING_J] = c.rolling_resistance * cj;
}

