// Hertz-Mindlin between candidate pairs (CpuBackend::pair_forces; the law is in contact.wgsl).
// One thread per pair; each writes its own history and output slot.
//
// history (per pair, 6): tangential spring xyz, rolling moment xyz
// output (per pair, 11): force on i xyz, torque on i xyz, torque on j xyz, rolling i, rolling j
// table (per material pair, 7): e_star, g_star, tangential damping ratio, hertz damping, static friction,
// rolling friction, surface energy

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
    for (var k = 0u; k < 11u; k++) {
        output[11u * q + k] = 0.0lf;
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_index(gid);
    if (q >= counts[1]) {
        return;
    }
    let n = counts[0];
    let i = pair_ij[2u * q];
    if (i == NO_BODY) {
        // An empty slot of a fixed-capacity row (the resident steps).
        return;
    }
    let j = pair_ij[2u * q + 1u];
    set_world(i);
    if (!stepping()) {
        return;
    }
    let body_i = ints[n + i];
    if (param(11u) != 0.0lf && body_i == ints[n + j] && body_i != NO_BODY) {
        // Members of one clump overlap by design.
        clear_output(q);
        return;
    }
    let delta = get3(3u * i) - get3(3u * j);
    let ri = props[i];
    let rj = props[j];
    let sum = ri + rj;
    let dist2 = len2(delta);
    let r_eff = ri * rj / sum;
    let t = u32(param(P_TABLE)) + 7u * (ints[i] * u32(param(15u)) + ints[j]);
    // A cohesive (JKR) pair attracts until the gap reaches the law's cut-off.
    var reach = sum;
    if (param(16u) != 0.0lf) {
        reach = sum - cutoff_of(t, r_eff);
    }
    if (dist2 >= reach * reach) {
        for (var k = 0u; k < 6u; k++) {
            history[6u * q + k] = 0.0lf;
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
    let wi = get3(6u * n + 3u * i);
    let wj = get3(6u * n + 3u * j);
    let m_eff = 1.0lf / (props[2u * n + i] + props[2u * n + j]);
    let v_rel = get3(3u * n + 3u * i) - get3(3u * n + 3u * j);
    let ai = props[n + i] * ri * ri;
    let aj = props[n + j] * rj * rj;
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
        hist3(6u * q),
        hist3(6u * q + 3u),
    );
    put_hist3(6u * q, c.shear);
    put_hist3(6u * q + 3u, c.moment);
    let nxf = cross3(nrm, c.tangential);
    put_out3(11u * q, c.force);
    put_out3(11u * q + 3u, -ci * nxf + c.rolling_torque);
    put_out3(11u * q + 6u, -cj * nxf - c.rolling_torque);
    output[11u * q + 9u] = c.rolling_resistance * ci;
    output[11u * q + 10u] = c.rolling_resistance * cj;
}

