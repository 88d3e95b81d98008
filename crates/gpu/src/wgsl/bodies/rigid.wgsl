// Rigid clumps (dem::clump): quaternions as vec4 (x, y, z, w), a body's row of `bodies` (BD_),
// its members' rows of `offsets` (MB_). Written in glam's order of operations, so that results
// match the CPU's.

fn quat_mul(a: vec4<f64>, b: vec4<f64>) -> vec4<f64> {
    return vec4<f64>(
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    );
}

// q v q^-1 for a unit q (glam's mul_vec3).
fn quat_rotate(q: vec4<f64>, v: vec3<f64>) -> vec3<f64> {
    let b = vec3<f64>(q.x, q.y, q.z);
    let b2 = dot3(b, b);
    return v * (q.w * q.w - b2) + b * (dot3(v, b) * 2.0lf) + cross3(b, v) * (q.w * 2.0lf);
}

fn quat_normalize(q: vec4<f64>) -> vec4<f64> {
    let len = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    return q * (1.0lf / len);
}

// The angular velocity in the space frame, R I^-1 R^T L (clump::omega).
fn body_omega(q: vec4<f64>, l: vec3<f64>, inertia: vec3<f64>) -> vec3<f64> {
    let body = quat_rotate(vec4<f64>(-q.x, -q.y, -q.z, q.w), l);
    return quat_rotate(q, body / inertia);
}

// dq/dt at fixed angular momentum.
fn quat_rate(q: vec4<f64>, l: vec3<f64>, inertia: vec3<f64>) -> vec4<f64> {
    let w = body_omega(q, l, inertia);
    return quat_mul(vec4<f64>(w.x, w.y, w.z, 0.0lf), q) * 0.5lf;
}

// RigidRotation::advance_orientation: LAMMPS' Richardson iteration.
fn advance_orientation(q: vec4<f64>, l: vec3<f64>, inertia: vec3<f64>, dt: f64) -> vec4<f64> {
    let dq = quat_rate(q, l, inertia);
    let full = quat_normalize(q + dq * dt);
    var half = quat_normalize(q + dq * (0.5lf * dt));
    half = quat_normalize(half + quat_rate(half, l, inertia) * (0.5lf * dt));
    return quat_normalize(half * 2.0lf - full);
}

fn body3(k: u32) -> vec3<f64> {
    return vec3<f64>(bodies[k], bodies[k + 1u], bodies[k + 2u]);
}

fn put_body3(k: u32, v: vec3<f64>) {
    bodies[k] = v.x;
    bodies[k + 1u] = v.y;
    bodies[k + 2u] = v.z;
}

fn body_quat(r: u32) -> vec4<f64> {
    let v = body3(r + BD_ORIENTATION);
    return vec4<f64>(v, bodies[r + BD_ORIENTATION_W]);
}

fn put_body_quat(r: u32, q: vec4<f64>) {
    put_body3(r + BD_ORIENTATION, vec3<f64>(q.x, q.y, q.z));
    bodies[r + BD_ORIENTATION_W] = q.w;
}

// The half kick of the body in row r under its stored force, torque and rolling limit
// (clump::kick_body): the rolling resistance brakes the angular momentum along the spin, at most
// to rest.
fn kick_body(r: u32, half_dt: f64) {
    let mass = bodies[r + BD_MASS];
    put_body3(r + BD_VELOCITY, body3(r + BD_VELOCITY) + body3(r + BD_FORCE) * (half_dt / mass));
    var l = body3(r + BD_ANGULAR_MOMENTUM) + body3(r + BD_TORQUE) * half_dt;
    let brake = bodies[r + BD_ROLLING_LIMIT] * half_dt;
    if (brake > 0.0lf) {
        let w = body_omega(body_quat(r), l, body3(r + BD_INERTIA));
        let s = sqrt(dot3(w, w));
        if (s > 0.0lf) {
            let dir = w / s;
            let along = dot3(l, dir);
            let cut = min(brake, max(along, 0.0lf));
            l = l - dir * cut;
        }
    }
    put_body3(r + BD_ANGULAR_MOMENTUM, l);
}

// Body b's members follow it: velocity and spin, and with `positions` their positions
// (Simulation::place_members).
fn place_members(b: u32, r: u32, positions: bool) {
    let n = counts[C_PARTICLES];
    let q = body_quat(r);
    let x = body3(r + BD_POSITION);
    let v = body3(r + BD_VELOCITY);
    let spin = body_omega(q, body3(r + BD_ANGULAR_MOMENTUM), body3(r + BD_INERTIA));
    for (var k = body_members[BM_LEN * b + BM_BEGIN]; k < body_members[BM_LEN * b + BM_END]; k++) {
        let i = members[k];
        let o = MB_LEN * k + MB_OFFSET;
        let arm = quat_rotate(q, vec3<f64>(offsets[o], offsets[o + 1u], offsets[o + 2u]));
        if (positions) {
            put3(S_POSITION * n + 3u * i, x + arm);
        }
        put3(S_VELOCITY * n + 3u * i, v + cross3(spin, arm));
        put3(S_ANGULAR_VELOCITY * n + 3u * i, spin);
    }
}

// The body's world (its first member's), or false when it does not step now.
fn body_steps(b: u32) -> bool {
    set_world(members[body_members[BM_LEN * b + BM_BEGIN]]);
    return stepping();
}
