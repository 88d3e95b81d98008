// The second half kick of particle i from its force, torque and rolling torque limit (the CPU's
// kick after the forces): needs COMMON, SPIN and STATE_WRITES, with `state` bound read_write.
fn second_half_kick(i: u32, f: vec3<f64>, t: vec3<f64>, lim: f64) {
    let n = counts[C_PARTICLES];
    let half = 0.5lf * param(P_DT);
    let v = velocity(i) + f * (props[PR_INV_MASS * n + i] * half);
    let w = kick_spin(angular_velocity(i), t, lim, props[PR_INV_INERTIA * n + i] * half);
    put3(S_VELOCITY * n + 3u * i, v);
    put3(S_ANGULAR_VELOCITY * n + 3u * i, w);
}
