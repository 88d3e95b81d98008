// The second half kick of a segment step, one thread per particle, from the loads
// particle_forces.wgsl summed (particle_sums' kick, in a launch of its own because the contacts
// read the velocities it changes): free spheres of a world with the kick flag, unless the
// world's bonds run with it (bonds/bond_sums.wgsl adds theirs first and kicks).

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> params: array<f64>;
@group(0) @binding(5) var<storage, read> counts: array<u32>;

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
    if (param(P_KICK) != 0.0lf && param(P_BONDS) == 0.0lf
        && (param(P_CLUMPS) == 0.0lf || body[i] == NO_BODY)) {
        let f = load3(L_FORCE * n + 3u * i);
        let t = load3(L_TORQUE * n + 3u * i);
        second_half_kick(i, f, t, loads[L_ROLLING_LIMIT * n + i]);
    }
}
