// Hertz-Mindlin (no slip, no cohesion) with the tangential spring and the chosen rolling model:
// contact::evaluate with contact::hertz_mindlin, contact::tangential_spring and contact::rolling,
// written once for particle pairs and particle-wall contacts. Reads the kernel's `table` (7
// numbers a material pair, from offset `t`) and `params` (dt 0, rolling model 13, rolling viscous
// damping 14).

struct Contact {
    // Total force on the particle (i): normal plus tangential.
    force: vec3<f64>,
    tangential: vec3<f64>,
    // epsd torque on the particle (zero for cdt).
    rolling_torque: vec3<f64>,
    // cdt: mu_r |F_n| (zero for epsd).
    rolling_resistance: f64,
    // The history after the step.
    shear: vec3<f64>,
    moment: vec3<f64>,
}

fn hertz_mindlin(
    t: u32,
    nrm: vec3<f64>,
    d: f64,
    r_eff: f64,
    m_eff: f64,
    v_rel: vec3<f64>,
    spin_lever: vec3<f64>,
    rel_spin: vec3<f64>,
    rolling_inertia: f64,
    shear_before: vec3<f64>,
    moment_before: vec3<f64>,
) -> Contact {
    let e_star = table[t];
    let g_star = table[t + 1u];
    let hertz_damping = table[t + 3u];
    let static_friction = table[t + 4u];
    let rolling_friction = table[t + 5u];
    let dt = params[0];

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
    var shear = shear_before;
    let old_len2 = len2(shear);
    if (old_len2 > 0.0lf) {
        let projected = shear - dot3(shear, nrm) * nrm;
        let new_len2 = len2(projected);
        if (new_len2 > 0.0lf) {
            shear = projected * sqrt(old_len2 / new_len2);
        } else {
            shear = zero3();
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
            shear = zero3();
        }
    }
    let secant = (4.0lf / 3.0lf) * e_star * a;

    // Rolling resistance: cdt leaves the moment history alone.
    var rolling_torque = zero3();
    var rolling_resistance = 0.0lf;
    var moment = moment_before;
    if (params[13] == 0.0lf) {
        rolling_resistance = rolling_friction * abs(load);
    } else {
        let w = rel_spin - dot3(rel_spin, nrm) * nrm;
        let k_r = 2.25lf * secant * rolling_friction * rolling_friction * r_eff * r_eff;
        moment = moment_before - dot3(moment_before, nrm) * nrm + k_r * w * dt;
        let lim = rolling_friction * r_eff * abs(load);
        let m2 = len2(moment);
        if (m2 > lim * lim) {
            moment *= lim / sqrt(m2);
            rolling_torque = -moment;
        } else {
            let damping = params[14] * 2.0lf * sqrt(rolling_inertia * k_r);
            rolling_torque = -(moment + damping * w);
        }
    }
    return Contact(f_n * nrm + f_t, f_t, rolling_torque, rolling_resistance, shear, moment);
}
