// A particle pair's contact, written once for pair_forces.wgsl (one thread a pair slot, writing
// its output row) and resident/particle_forces.wgsl (both particles of a pair evaluate it): the
// same arithmetic in the same order (CpuBackend::pair_forces). Needs COMMON and CONTACT, with
// `ints` and `table` bound. The history is read only for a pair in touch (`pair_law`).

// What a pair contact adds to its two particles (the pair output row's numbers).
struct PairLoads {
    // On i; j gets its negative.
    force: vec3<f64>,
    torque_i: vec3<f64>,
    torque_j: vec3<f64>,
    rolling_i: f64,
    rolling_j: f64,
}

// A pair's geometry before its history is read.
struct PairGap {
    // Within reach (the JKR cut-off for a cohesive pair).
    touching: bool,
    // The material pair's row of the table.
    t: u32,
    nrm: vec3<f64>,
    d: f64,
    r_eff: f64,
    // The contact point's distances from the centres.
    ci: f64,
    cj: f64,
}

fn no_pair_loads() -> PairLoads {
    return PairLoads(zero3(), zero3(), zero3(), 0.0lf, 0.0lf);
}

// Members of one clump overlap by design and do not touch each other.
fn same_clump(i: u32, j: u32) -> bool {
    let n = counts[C_PARTICLES];
    let body_i = ints[I_BODY * n + i];
    return param(P_CLUMPS) != 0.0lf && body_i == ints[I_BODY * n + j] && body_i != NO_BODY;
}

fn pair_gap(i: u32, j: u32) -> PairGap {
    let n = counts[C_PARTICLES];
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
        return PairGap(false, t, zero3(), 0.0lf, r_eff, 0.0lf, 0.0lf);
    }
    let dist = sqrt(dist2);
    // As the CPU: one division, then products.
    let nrm = delta * (1.0lf / dist);
    let d = sum - dist;
    return PairGap(true, t, nrm, d, r_eff, ri - 0.5lf * d, rj - 0.5lf * d);
}

// The law for a pair in touch, from its tangential and rolling history before the step.
fn pair_law(i: u32, j: u32, g: PairGap, shear: vec3<f64>, moment: vec3<f64>) -> Contact {
    let n = counts[C_PARTICLES];
    let wi = angular_velocity(i);
    let wj = angular_velocity(j);
    let m_eff = 1.0lf / (props[PR_INV_MASS * n + i] + props[PR_INV_MASS * n + j]);
    let v_rel = velocity(i) - velocity(j);
    let ri = props[PR_RADIUS * n + i];
    let rj = props[PR_RADIUS * n + j];
    let ai = props[PR_MASS * n + i] * ri * ri;
    let aj = props[PR_MASS * n + j] * rj * rj;
    return hertz_mindlin(
        g.t,
        g.nrm,
        g.d,
        g.r_eff,
        m_eff,
        v_rel,
        g.ci * wi + g.cj * wj,
        wi - wj,
        1.4lf * ai * aj / (ai + aj),
        shear,
        moment,
    );
}

fn pair_loads(g: PairGap, c: Contact) -> PairLoads {
    let nxf = cross3(g.nrm, c.tangential);
    return PairLoads(
        c.force,
        -g.ci * nxf + c.rolling_torque,
        -g.cj * nxf - c.rolling_torque,
        c.rolling_resistance * g.ci,
        c.rolling_resistance * g.cj,
    );
}
