// After the forces, for each clump (Simulation::gather_bodies, then its kick): its members'
// forces and torques gathered (each member's force holds gravity on the whole body's mass, which
// is taken off, the body's weight added once), the second half kick, and its members' velocity
// and spin placed. Runs after the particle sums (and the bond sums), which leave the members
// unkicked.

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> params: array<f64>;
@group(0) @binding(3) var<storage, read> counts: array<u32>;
@group(0) @binding(4) var<storage, read_write> bodies: array<f64>;
@group(0) @binding(5) var<storage, read> body_members: array<u32>;
@group(0) @binding(6) var<storage, read> members: array<u32>;
@group(0) @binding(7) var<storage, read> offsets: array<f64>;
@group(0) @binding(8) var<storage, read> loads: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = thread_index(gid);
    if (b >= counts[C_BODIES] || !body_steps(b)) {
        return;
    }
    let n = counts[C_PARTICLES];
    let r = BD_LEN * b;
    let g = param3(P_GRAVITY);
    let x = body3(r + BD_POSITION);
    var f = g * bodies[r + BD_MASS];
    var t = zero3();
    var lim = 0.0lf;
    for (var k = body_members[BM_LEN * b + BM_BEGIN]; k < body_members[BM_LEN * b + BM_END]; k++) {
        let i = members[k];
        let contact = load3(L_FORCE * n + 3u * i) - g * props[PR_MASS * n + i];
        f += contact;
        t += cross3(position(i) - x, contact) + load3(L_TORQUE * n + 3u * i);
        lim += loads[L_ROLLING_LIMIT * n + i];
    }
    put_body3(r + BD_FORCE, f);
    put_body3(r + BD_TORQUE, t);
    bodies[r + BD_ROLLING_LIMIT] = lim;
    kick_body(r, 0.5lf * param(P_DT));
    place_members(b, r, false);
}
