// Shared by the kernels that bind `state`, `props`, `params` and `counts` (the stage kernels and
// the segment kernels that look at particles): the accessors of those buffers. Their layouts are
// the generated constants (crates/gpu/src/layout.rs): S_ for state, PR_ for props, P_ for a
// world's params block, C_ for counts.
//
// A batch runs several simulations ("worlds") in the same launches: every particle carries its
// world (PR_WORLD), and every world has a block of P_LEN numbers in params.

const NO_BODY: u32 = 0xffffffffu;

// The params block of the particle a thread works for (set_world).
var<private> pbase: u32;

fn set_world(i: u32) {
    pbase = P_LEN * u32(props[PR_WORLD * counts[C_PARTICLES] + i]);
}

fn param(k: u32) -> f64 {
    return params[pbase + k];
}

// Whether the thread's world steps now.
fn stepping() -> bool {
    return param(P_STEPPING) == 1.0lf;
}

fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * counts[C_ROW_WIDTH];
}

fn get3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

// Particle i's vector in `block` of state (S_POSITION, S_VELOCITY, S_ANGULAR_VELOCITY).
fn state3(block: u32, i: u32) -> vec3<f64> {
    return get3(block * counts[C_PARTICLES] + 3u * i);
}

fn position(i: u32) -> vec3<f64> {
    return state3(S_POSITION, i);
}

fn velocity(i: u32) -> vec3<f64> {
    return state3(S_VELOCITY, i);
}

fn angular_velocity(i: u32) -> vec3<f64> {
    return state3(S_ANGULAR_VELOCITY, i);
}

fn param3(k: u32) -> vec3<f64> {
    return vec3<f64>(param(k), param(k + 1u), param(k + 2u));
}
