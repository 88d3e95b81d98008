// Hertz-Mindlin (no slip) with optional JKR cohesion, the tangential spring and the chosen
// rolling model: contact::evaluate with contact::hertz_mindlin, contact::jkr,
// contact::tangential_spring and contact::rolling, written once for particle pairs and
// particle-wall contacts. Reads the kernel's `table` (the material pair's row of T_LEN from
// `t`) and `params` (P_DT, P_ROLLING_MODEL, P_ROLLING_DAMPING).

const PI: f64 = 3.141592653589793lf;
const FRAC_1_SQRT_2: f64 = 0.7071067811865476lf;

// Cube root of x > 0: WGSL's f64 has no pow, so Newton's iteration refines the f32 root (7
// digits) to f64 round-off in two steps; the third settles the last bit.
fn cbrt64(x: f64) -> f64 {
    if (x <= 0.0lf) {
        return 0.0lf;
    }
    var y = f64(pow(f32(x), 1.0 / 3.0));
    for (var k = 0; k < 3; k++) {
        y = y - (y * y * y - x) / (3.0lf * y * y);
    }
    return y;
}

// contact::jkr_cutoff_overlap: the (negative) overlap down to which a JKR contact attracts.
fn jkr_cutoff_overlap(gamma: f64, e_star: f64, r_eff: f64) -> f64 {
    if (gamma <= 0.0lf) {
        return 0.0lf;
    }
    let a_c = cbrt64(9.0lf * PI * gamma * r_eff * r_eff / (2.0lf * e_star) * (0.75lf - FRAC_1_SQRT_2));
    return a_c * a_c / r_eff - sqrt(4.0lf * PI * gamma * a_c / e_star);
}

// The cut-off overlap of material pair `t` at effective radius r_eff.
fn cutoff_of(t: u32, r_eff: f64) -> f64 {
    return jkr_cutoff_overlap(table[t + T_SURFACE_ENERGY], table[t + T_E_STAR], r_eff);
}

// contact::jkr_contact_radius: Newton on g(s) = s^4/R* - c s - d from a point where g >= 0.
fn jkr_contact_radius(d: f64, gamma: f64, e_star: f64, r_eff: f64) -> f64 {
    let c = sqrt(4.0lf * PI * gamma / e_star);
    let s_min = cbrt64(c * r_eff / 4.0lf);
    var s = sqrt(sqrt(r_eff * max(d, 0.0lf))) + cbrt64(c * r_eff);
    for (var k = 0; k < 60; k++) {
        let s2 = s * s;
        let g = s2 * s2 / r_eff - c * s - d;
        let slope = 4.0lf * (s2 * s) / r_eff - c;
        if (slope <= 0.0lf) {
            break;
        }
        let next = max(s - g / slope, s_min);
        if (abs(s - next) <= 1.0e-14lf * s) {
            s = next;
            break;
        }
        s = next;
    }
    return s * s;
}

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
    let e_star = table[t + T_E_STAR];
    let g_star = table[t + T_G_STAR];
    let tangential_damping_ratio = table[t + T_TANGENTIAL_DAMPING_RATIO];
    let hertz_damping = table[t + T_HERTZ_DAMPING];
    let static_friction = table[t + T_STATIC_FRICTION];
    let rolling_friction = table[t + T_ROLLING_FRICTION];
    let gamma = table[t + T_SURFACE_ENERGY];
    let dt = param(P_DT);

    // Hertz (or with a surface energy JKR) normal force and the Mindlin tangential stiffness.
    var a = 0.0lf;
    var f_elastic = 0.0lf;
    var pull_off = 0.0lf;
    if (gamma > 0.0lf) {
        a = jkr_contact_radius(d, gamma, e_star, r_eff);
        f_elastic = (4.0lf * e_star / (3.0lf * r_eff)) * a * a * a
            - 4.0lf * sqrt(PI * gamma * e_star) * (a * sqrt(a));
        pull_off = 6.0lf * PI * gamma * r_eff;
    } else {
        a = sqrt(r_eff * d);
        f_elastic = (4.0lf / 3.0lf) * e_star * a * d;
    }
    let s_n = 2.0lf * e_star * a;
    let s_t = 8.0lf * g_star * a;
    let v_n = dot3(v_rel, nrm);
    let gamma_n = hertz_damping * sqrt(s_n * m_eff);
    let f_n = f_elastic - gamma_n * v_n;
    let v_t = v_rel - v_n * nrm;
    let v_c = v_t - cross3(spin_lever, nrm);
    // As the CPU: the normal coefficient times sqrt(S_t / S_n) where the table has that ratio.
    var gamma_t = hertz_damping * sqrt(s_t * m_eff);
    if (tangential_damping_ratio > 0.0lf) {
        gamma_t = gamma_n * tangential_damping_ratio;
    }
    let load = f_n + pull_off;
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
    // 0 cdt, 1 epsd.
    if (param(P_ROLLING_MODEL) == 0.0lf) {
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
            let damping = param(P_ROLLING_DAMPING) * 2.0lf * sqrt(rolling_inertia * k_r);
            rolling_torque = -(moment + damping * w);
        }
    }
    return Contact(f_n * nrm + f_t, f_t, rolling_torque, rolling_resistance, shear, moment);
}
