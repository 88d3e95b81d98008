// Each particle of a world with bonds adds its bonds' outputs to the force and torque the
// particle sums left, in bond order (dem::bond::Bonds::apply), then the bonds' local damping (a
// held sphere, of infinite mass, is not damped: a tool reads its force), then the second half
// kick that the particle sums leave to this kernel in such a world.
//
// rows (u32): blocks of N (BN_), a particle's range of bond slots, then the slots (2 b: the
// first sphere of bond b, 2 b + 1: its second).

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read_write> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> params: array<f64>;
@group(0) @binding(4) var<storage, read> counts: array<u32>;
@group(0) @binding(5) var<storage, read> rows: array<u32>;
@group(0) @binding(6) var<storage, read> ends: array<u32>;
@group(0) @binding(7) var<storage, read> bond_params: array<f64>;
@group(0) @binding(8) var<storage, read> bond_output: array<f64>;
@group(0) @binding(9) var<storage, read> body: array<u32>;

fn output_at(k: u32) -> vec3<f64> {
    return vec3<f64>(bond_output[k], bond_output[k + 1u], bond_output[k + 2u]);
}

fn sign_of(x: f64) -> f64 {
    if (x > 0.0lf) {
        return 1.0lf;
    }
    if (x < 0.0lf) {
        return -1.0lf;
    }
    return 0.0lf;
}

// PFC local damping of f component by component against v (kernel::local_damping).
fn local_damping(f: vec3<f64>, v: vec3<f64>, fraction: f64) -> vec3<f64> {
    return f - fraction * vec3<f64>(abs(f.x) * sign_of(v.x), abs(f.y) * sign_of(v.y), abs(f.z) * sign_of(v.z));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[C_PARTICLES];
    if (i >= n) {
        return;
    }
    set_world(i);
    if (!stepping() || param(P_BONDS) == 0.0lf) {
        return;
    }
    var f = load3(L_FORCE * n + 3u * i);
    var t = load3(L_TORQUE * n + 3u * i);
    var damping = 0.0lf;
    for (var k = rows[BN_BEGIN * n + i]; k < rows[BN_END * n + i]; k++) {
        let slot = rows[BN_SLOTS * n + k];
        let b = slot >> 1u;
        let e = BE_LEN * b;
        if (ends[e + BE_INTACT] == 0u) {
            continue;
        }
        let o = BO_LEN * b;
        if ((slot & 1u) == 0u) {
            f += output_at(o + BO_FORCE);
            t += output_at(o + BO_TORQUE_FIRST);
        } else {
            f -= output_at(o + BO_FORCE);
            t += output_at(o + BO_TORQUE_SECOND);
        }
        damping = max(damping, bond_params[BP_LEN * ends[e + BE_KIND] + BP_DAMPING]);
    }
    let inv_mass = props[PR_INV_MASS * n + i];
    if (damping > 0.0lf && inv_mass > 0.0lf) {
        f = local_damping(f, velocity(i), damping);
        t = local_damping(t, angular_velocity(i), damping);
    }
    put_load3(L_FORCE * n + 3u * i, f);
    put_load3(L_TORQUE * n + 3u * i, t);
    // A clump's members are kicked with their body (bodies/bodies_last.wgsl).
    if (param(P_KICK) != 0.0lf && (param(P_CLUMPS) == 0.0lf || body[i] == NO_BODY)) {
        second_half_kick(i, f, t, loads[L_ROLLING_LIMIT * n + i]);
    }
}
