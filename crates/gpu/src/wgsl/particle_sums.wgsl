// Each particle sums gravity, its pair slots (as i and as j) and its wall slots in a fixed order
// into its force, torque and rolling torque limit; with the kick flag, free spheres get the second
// half kick (CpuBackend::particle_sums), unless the world's bonds run with it.
//
// rows (u32): blocks of N (R_), a particle's pair slots R_PAIR_BEGIN..R_PAIR_END, its reverse
//   entries (the pair slots where it is j) and its wall candidate slots likewise
// pairs: the pair kernel's output (rows of PO_LEN); walls: the wall kernel's (rows of WO_LEN)

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read_write> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> pairs: array<f64>;
@group(0) @binding(5) var<storage, read> rows: array<u32>;
@group(0) @binding(6) var<storage, read> walls: array<f64>;
@group(0) @binding(7) var<storage, read> params: array<f64>;
@group(0) @binding(8) var<storage, read> counts: array<u32>;

fn pair3(k: u32) -> vec3<f64> {
    return vec3<f64>(pairs[k], pairs[k + 1u], pairs[k + 2u]);
}

fn wall3(k: u32) -> vec3<f64> {
    return vec3<f64>(walls[k], walls[k + 1u], walls[k + 2u]);
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
    var f = param3(P_GRAVITY) * props[PR_MASS * n + i];
    var t = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var lim = 0.0lf;
    for (var q = rows[R_PAIR_BEGIN * n + i]; q < rows[R_PAIR_END * n + i]; q++) {
        f += pair3(PO_LEN * q + PO_FORCE);
        t += pair3(PO_LEN * q + PO_TORQUE_I);
        lim += pairs[PO_LEN * q + PO_ROLLING_I];
    }
    for (var k = rows[R_REVERSE_BEGIN * n + i]; k < rows[R_REVERSE_END * n + i]; k++) {
        let q = rows[R_REVERSE_ENTRIES * n + k];
        f -= pair3(PO_LEN * q + PO_FORCE);
        t += pair3(PO_LEN * q + PO_TORQUE_J);
        lim += pairs[PO_LEN * q + PO_ROLLING_J];
    }
    for (var c = rows[R_WALL_BEGIN * n + i]; c < rows[R_WALL_END * n + i]; c++) {
        f -= wall3(WO_LEN * c + WO_FORCE);
        t += wall3(WO_LEN * c + WO_PARTICLE_TORQUE);
        lim += walls[WO_LEN * c + WO_ROLLING];
    }
    put_load3(L_FORCE * n + 3u * i, f);
    put_load3(L_TORQUE * n + 3u * i, t);
    loads[L_ROLLING_LIMIT * n + i] = lim;
    // In a world with bonds the bond sums add theirs first and kick (bonds/bond_sums.wgsl).
    if (param(P_KICK) != 0.0lf && param(P_BONDS) == 0.0lf
        && (param(P_CLUMPS) == 0.0lf || body[i] == NO_BODY)) {
        second_half_kick(i, f, t, lim);
    }
}
