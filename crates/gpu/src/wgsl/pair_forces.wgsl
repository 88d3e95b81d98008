// Hertz-Mindlin (no slip) between candidate pairs, with the tangential spring and the rolling
// resistance of the chosen model (CpuBackend::pair_forces with contact::hertz_mindlin,
// contact::tangential_spring and contact::rolling). One thread per pair; each writes its own
// history and output slot.
//
// history (per pair, 6): tangential spring xyz, rolling moment xyz
// output (per pair, 11): force on i xyz, torque on i xyz, torque on j xyz, rolling i, rolling j
// table (per material pair, 7): e_star, g_star, damping ratio, hertz damping, static friction,
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

fn get3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

fn hist3(k: u32) -> vec3<f64> {
    return vec3<f64>(history[k], history[k + 1u], history[k + 2u]);
}

fn put_hist3(k: u32, v: vec3<f64>) {
    history[k] = v.x;
    history[k + 1u] = v.y;
    history[k + 2u] = v.z;
}

fn put_out3(k: u32, v: vec3<f64>) {
    output[k] = v.x;
    output[k + 1u] = v.y;
    output[k + 2u] = v.z;
}

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
    let j = pair_ij[2u * q + 1u];
    let body_i = ints[n + i];
    if (params[11] != 0.0lf && body_i == ints[n + j] && body_i != NO_BODY) {
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
    if (dist2 >= sum * sum) {
        for (var k = 0u; k < 6u; k++) {
            history[6u * q + k] = 0.0lf;
        }
        clear_output(q);
        return;
    }
    let dist = sqrt(dist2);
    let nrm = delta / dist;
    let d = sum - dist;
    let ci = ri - 0.5lf * d;
    let cj = rj - 0.5lf * d;
    let wi = get3(6u * n + 3u * i);
    let wj = get3(6u * n + 3u * j);
    let m_eff = 1.0lf / (props[2u * n + i] + props[2u * n + j]);
    let mats = u32(params[15]);
    let t = 7u * (ints[i] * mats + ints[j]);
    let e_star = table[t];
    let g_star = table[t + 1u];
    let hertz_damping = table[t + 3u];
    let static_friction = table[t + 4u];
    let rolling_friction = table[t + 5u];
    let dt = params[0];
    let v_rel = get3(3u * n + 3u * i) - get3(3u * n + 3u * j);
    let spin_lever = ci * wi + cj * wj;

    // Hertz normal force and the Mindlin tangential stiffness.
    let a = sqrt(r_eff * d);
    let f_elastic = (4.0lf / 3.0lf) * e_star * a * d;
    let s_n = 2.0lf * e_star * a;
    let s_t = 8.0lf * g_star * a;
    let v_n = dot3(v_rel, nrm);
    let gamma_n = hertz_damping * sqrt(s_n * m_eff);
    let f_n = f_elastic - gamma_n * v_n;
    let v_t = v_rel - v_n * nrm;
    let v_c = v_t - cross3(spin_lever, nrm);
    let gamma_t = hertz_damping * sqrt(s_t * m_eff);
    let load = f_n;
    let limit = static_friction * abs(load);

    // The tangential spring, rotated into the contact plane, capped by friction.
    var shear = hist3(6u * q);
    let old_len2 = len2(shear);
    if (old_len2 > 0.0lf) {
        let projected = shear - dot3(shear, nrm) * nrm;
        let new_len2 = len2(projected);
        if (new_len2 > 0.0lf) {
            shear = projected * sqrt(old_len2 / new_len2);
        } else {
            shear = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
        }
    }
    shear += v_c * dt;
    var f_t = -s_t * shear - gamma_t * v_c;
    let ft2 = len2(f_t);
    if (ft2 > limit * limit) {
        f_t *= limit / sqrt(ft2);
        if (s_t > 0.0lf) {
            shear = -(f_t + gamma_t * v_c) / s_t;
        } else {
            shear = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
        }
    }
    put_hist3(6u * q, shear);
    let secant = (4.0lf / 3.0lf) * e_star * a;

    // Rolling resistance.
    var rolling_torque = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var rolling_resistance = 0.0lf;
    if (params[13] == 0.0lf) {
        rolling_resistance = rolling_friction * abs(load);
    } else {
        let rel_spin = wi - wj;
        let w = rel_spin - dot3(rel_spin, nrm) * nrm;
        let k_r = 2.25lf * secant * rolling_friction * rolling_friction * r_eff * r_eff;
        let moment = hist3(6u * q + 3u);
        var m = moment - dot3(moment, nrm) * nrm + k_r * w * dt;
        let lim = rolling_friction * r_eff * abs(load);
        let m2 = len2(m);
        if (m2 > lim * lim) {
            m *= lim / sqrt(m2);
            rolling_torque = -m;
        } else {
            let ai = props[n + i] * ri * ri;
            let aj = props[n + j] * rj * rj;
            let inertia = 1.4lf * ai * aj / (ai + aj);
            let damping = params[14] * 2.0lf * sqrt(inertia * k_r);
            rolling_torque = -(m + damping * w);
        }
        put_hist3(6u * q + 3u, m);
    }

    let force = f_n * nrm + f_t;
    let nxf = cross3(nrm, f_t);
    put_out3(11u * q, force);
    put_out3(11u * q + 3u, -ci * nxf + rolling_torque);
    put_out3(11u * q + 6u, -cj * nxf - rolling_torque);
    output[11u * q + 9u] = rolling_resistance * ci;
    output[11u * q + 10u] = rolling_resistance * cj;
}
