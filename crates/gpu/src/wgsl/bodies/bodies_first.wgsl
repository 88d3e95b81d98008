// The first half of a step for each clump (Simulation::bodies_first_half): the half kick under
// the force of the last step, the drift and the turn, then its members placed (position,
// velocity, spin). Runs before `integrate`, which leaves the members alone.
//
// bodies (rows of BD_LEN), body_members (u32 rows of BM_LEN: a body's range of `members`),
// members (u32, particle indices), offsets (each member's offset in the body frame, 3 numbers).

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> params: array<f64>;
@group(0) @binding(3) var<storage, read> counts: array<u32>;
@group(0) @binding(4) var<storage, read_write> bodies: array<f64>;
@group(0) @binding(5) var<storage, read> body_members: array<u32>;
@group(0) @binding(6) var<storage, read> members: array<u32>;
@group(0) @binding(7) var<storage, read> offsets: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = thread_index(gid);
    if (b >= counts[C_BODIES] || !body_steps(b)) {
        return;
    }
    let dt = param(P_DT);
    let r = BD_LEN * b;
    kick_body(r, 0.5lf * dt);
    let v = body3(r + BD_VELOCITY);
    put_body3(r + BD_POSITION, body3(r + BD_POSITION) + v * dt);
    let q = advance_orientation(body_quat(r), body3(r + BD_ANGULAR_MOMENTUM), body3(r + BD_INERTIA), dt);
    put_body_quat(r, q);
    place_members(b, r, true);
}
