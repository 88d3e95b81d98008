// A segment step's loads, one thread per particle (the stage kernels pair_forces and
// particle_sums in one, with no per-pair output): gravity, then every contact of the particle's
// pair row (where it is i) and of its reverse row (where it is j), each evaluated here from the
// pair's history before the step, then its wall slots (wall_forces' output), summed in
// particle_sums' order (the second half kick is the next launch's, `kick.wgsl`: the contacts
// here read the velocities it changes). Both particles of a pair
// evaluate it, with the same arithmetic on the same numbers, so the force on j is the exact
// negative of the force on i, as on the CPU; only i writes the history after the step, into the
// other half (history_halves.wgsl), so that j still reads the one before it. The second
// evaluation costs arithmetic; the per-pair output it replaces cost 11 numbers written and read
// per pair slot and step.

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read_write> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> ints: array<u32>;
@group(0) @binding(4) var<storage, read> pair_ij: array<u32>;
@group(0) @binding(5) var<storage, read_write> history_even: array<f64>;
@group(0) @binding(6) var<storage, read_write> history_odd: array<f64>;
@group(0) @binding(7) var<storage, read> rows: array<u32>;
@group(0) @binding(8) var<storage, read> walls: array<f64>;
@group(0) @binding(9) var<storage, read> table: array<f64>;
@group(0) @binding(10) var<storage, read> params: array<f64>;
@group(0) @binding(11) var<storage, read> counts: array<u32>;
@group(0) @binding(12) var<storage, read_write> ctrl: array<atomic<u32>>;

// What a pair contact adds to its two particles (pair_forces' output row).
struct PairLoads {
    // On i; j gets its negative.
    force: vec3<f64>,
    torque_i: vec3<f64>,
    torque_j: vec3<f64>,
    rolling_i: f64,
    rolling_j: f64,
}

fn wall3(k: u32) -> vec3<f64> {
    return vec3<f64>(walls[k], walls[k + 1u], walls[k + 2u]);
}

// Pair slot q (particles i < j) from its history in half `h`, as pair_forces evaluates it; where
// `owner` (the thread of i), the history after the step goes to the other half.
fn pair_contact(q: u32, i: u32, j: u32, h: u32, owner: bool) -> PairLoads {
    let none = PairLoads(zero3(), zero3(), zero3(), 0.0lf, 0.0lf);
    let n = counts[C_PARTICLES];
    let next = 1u - h;
    let body_i = ints[I_BODY * n + i];
    if (param(P_CLUMPS) != 0.0lf && body_i == ints[I_BODY * n + j] && body_i != NO_BODY) {
        // Members of one clump overlap by design; their history stays as it was.
        if (owner) {
            for (var k = 0u; k < H_LEN; k++) {
                half_put(next, H_LEN * q + k, half_get(h, H_LEN * q + k));
            }
        }
        return none;
    }
    let delta = position(i) - position(j);
    let ri = props[PR_RADIUS * n + i];
    let rj = props[PR_RADIUS * n + j];
    let sum = ri + rj;
    let dist2 = len2(delta);
    let r_eff = ri * rj / sum;
    let mi = ints[I_MATERIAL * n + i];
    let mj = ints[I_MATERIAL * n + j];
    let t = u32(param(P_TABLE)) + T_LEN * (mi * u32(param(P_MATERIALS)) + mj);
    var reach = sum;
    if (param(P_COHESIVE) != 0.0lf) {
        reach = sum - cutoff_of(t, r_eff);
    }
    if (dist2 >= reach * reach) {
        if (owner) {
            for (var k = 0u; k < H_LEN; k++) {
                half_put(next, H_LEN * q + k, 0.0lf);
            }
        }
        return none;
    }
    let dist = sqrt(dist2);
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
        half_get3(h, H_LEN * q + H_TANGENTIAL),
        half_get3(h, H_LEN * q + H_ROLLING),
    );
    if (owner) {
        half_put3(next, H_LEN * q + H_TANGENTIAL, c.shear);
        half_put3(next, H_LEN * q + H_ROLLING, c.moment);
    }
    let nxf = cross3(nrm, c.tangential);
    return PairLoads(
        c.force,
        -ci * nxf + c.rolling_torque,
        -cj * nxf - c.rolling_torque,
        c.rolling_resistance * ci,
        c.rolling_resistance * cj,
    );
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[C_PARTICLES];
    if (i >= n) {
        return;
    }
    set_world(i);
    if (!stepping()) {
        return;
    }
    let h = history_half();
    var f = param3(P_GRAVITY) * props[PR_MASS * n + i];
    var t = zero3();
    var lim = 0.0lf;
    for (var q = rows[R_PAIR_BEGIN * n + i]; q < rows[R_PAIR_END * n + i]; q++) {
        let c = pair_contact(q, i, pair_ij[IJ_LEN * q + IJ_J], h, true);
        f += c.force;
        t += c.torque_i;
        lim += c.rolling_i;
    }
    for (var k = rows[R_REVERSE_BEGIN * n + i]; k < rows[R_REVERSE_END * n + i]; k++) {
        let q = rows[R_REVERSE_ENTRIES * n + k];
        let c = pair_contact(q, pair_ij[IJ_LEN * q + IJ_I], i, h, false);
        f -= c.force;
        t += c.torque_j;
        lim += c.rolling_j;
    }
    for (var s = rows[R_WALL_BEGIN * n + i]; s < rows[R_WALL_END * n + i]; s++) {
        f -= wall3(WO_LEN * s + WO_FORCE);
        t += wall3(WO_LEN * s + WO_PARTICLE_TORQUE);
        lim += walls[WO_LEN * s + WO_ROLLING];
    }
    put_load3(L_FORCE * n + 3u * i, f);
    put_load3(L_TORQUE * n + 3u * i, t);
    loads[L_ROLLING_LIMIT * n + i] = lim;
}
