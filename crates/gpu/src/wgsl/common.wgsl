// Shared by the kernels of the stages: the layout of the params and counts buffers, and their
// accessors (the kernels that include this bind `state`, `params` and `counts`).
//
// params (f64): 0 dt, 1..3 gravity, 4 has_domain, 5..7 domain low, 8..10 domain high,
// 11 clumps, 12 kick, 13 rolling model (0 cdt, 1 epsd), 14 rolling viscous damping,
// 15 number of materials, 16 cohesive (some material pair has a surface energy).
// counts (u32): 0 particles, 1 pairs, 2 reverse entries, 3 wall candidates, 4 row width of a
// 2-D dispatch (threads).

const NO_BODY: u32 = 0xffffffffu;

fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * counts[4];
}

// Every kernel binds `state`, positions first.
fn get3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

fn param3(k: u32) -> vec3<f64> {
    return vec3<f64>(params[k], params[k + 1u], params[k + 2u]);
}
