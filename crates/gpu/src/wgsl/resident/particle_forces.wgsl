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
@group(0) @binding(5) var<storage, read> rows: array<u32>;
@group(0) @binding(6) var<storage, read> table: array<f64>;
@group(0) @binding(7) var<storage, read> params: array<f64>;
@group(0) @binding(8) var<storage, read> counts: array<u32>;
@group(0) @binding(9) var<storage, read_write> ctrl: array<atomic<u32>>;
// After these: the pair histories' halves and the wall outputs (`walls`), each in parts
// (`kernels::split_lists`).

fn wall3(k: u32) -> vec3<f64> {
    return vec3<f64>(walls_get(k), walls_get(k + 1u), walls_get(k + 2u));
}

// Pair slot q (particles i < j) from its history in half `h` (pair_contact.wgsl); where `owner`
// (the thread of i), the history after the step goes to the other half.
fn pair_contact(q: u32, i: u32, j: u32, h: u32, owner: bool) -> PairLoads {
    let next = 1u - h;
    if (same_clump(i, j)) {
        // Their history stays as it was.
        if (owner) {
            for (var k = 0u; k < H_LEN; k++) {
                half_put(next, H_LEN * q + k, half_get(h, H_LEN * q + k));
            }
        }
        return no_pair_loads();
    }
    let g = pair_gap(i, j);
    if (!g.touching) {
        if (owner) {
            for (var k = 0u; k < H_LEN; k++) {
                half_put(next, H_LEN * q + k, 0.0lf);
            }
        }
        return no_pair_loads();
    }
    let c = pair_law(
        i,
        j,
        g,
        half_get3(h, H_LEN * q + H_TANGENTIAL),
        half_get3(h, H_LEN * q + H_ROLLING),
    );
    if (owner) {
        half_put3(next, H_LEN * q + H_TANGENTIAL, c.shear);
        half_put3(next, H_LEN * q + H_ROLLING, c.moment);
    }
    return pair_loads(g, c);
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
        lim += walls_get(WO_LEN * s + WO_ROLLING);
    }
    put_load3(L_FORCE * n + 3u * i, f);
    put_load3(L_TORQUE * n + 3u * i, t);
    loads[L_ROLLING_LIMIT * n + i] = lim;
}
