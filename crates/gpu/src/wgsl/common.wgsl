// Shared by the kernels of the stages: the layout of the params and counts buffers, and their
// accessors (the kernels that include this bind `state`, `props`, `params` and `counts`).
//
// A batch runs several simulations ("worlds") in the same launches: every particle carries its
// world (props block 4), and every world has a block of PARAMS numbers in params:
// 0 dt, 1..3 gravity, 4 has_domain, 5..7 domain low, 8..10 domain high,
// 11 clumps, 12 kick, 13 rolling model (0 cdt, 1 epsd), 14 rolling viscous damping,
// 15 number of materials,
// 16 cohesive (some material pair has a surface energy), 17 stepping (1 stepping, 2 its steps
// just ended: checked only, 0 done), 18 the world's steps, 19..20 its first and end geometry,
// 21..22 its first and end particle, 23 where its material pair table starts (world.wgsl names
// 17..23). Material and geometry indices are the world's own.
// counts (u32): 0 particles, 1 pairs, 2 reverse entries, 3 wall candidates, 4 row width of a
// 2-D dispatch (threads).

const NO_BODY: u32 = 0xffffffffu;

// The params block of the particle a thread works for (set_world).
var<private> pbase: u32;

fn set_world(i: u32) {
    pbase = PARAMS * u32(props[4u * counts[0] + i]);
}

fn param(k: u32) -> f64 {
    return params[pbase + k];
}

// Whether the thread's world steps now.
fn stepping() -> bool {
    return param(P_STEPPING) == 1.0lf;
}

fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * counts[4];
}

// Every kernel binds `state`, positions first.
fn get3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

fn param3(k: u32) -> vec3<f64> {
    return vec3<f64>(param(k), param(k + 1u), param(k + 2u));
}
