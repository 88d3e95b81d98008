// Half kick and drift of every free sphere (CpuBackend::integrate), and each particle's squared
// displacement since the last list build. The host finds the largest, and the first particle that
// is not finite or has left the domain (flag 1).
//
// state: position 3N | velocity 3N | angular velocity 3N
// loads: force 3N | torque 3N | rolling torque limit N
// props: radius N | mass N | inverse mass N | inverse inertia N | world N

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> built: array<f64>;
@group(0) @binding(5) var<storage, read> params: array<f64>;
@group(0) @binding(6) var<storage, read> counts: array<u32>;
@group(0) @binding(7) var<storage, read_write> moved: array<f64>;
@group(0) @binding(8) var<storage, read_write> outside: array<u32>;

fn put3(k: u32, v: vec3<f64>) {
    state[k] = v.x;
    state[k + 1u] = v.y;
    state[k + 2u] = v.z;
}

fn load3(k: u32) -> vec3<f64> {
    return vec3<f64>(loads[k], loads[k + 1u], loads[k + 2u]);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[0];
    if (i >= n) {
        return;
    }
    set_world(i);
    if (!stepping()) {
        return;
    }
    let dt = param(0u);
    let half = 0.5lf * dt;
    var x = get3(3u * i);
    if (param(11u) == 0.0lf || body[i] == NO_BODY) {
        var v = get3(3u * n + 3u * i);
        let w = get3(6u * n + 3u * i);
        v += load3(3u * i) * (props[2u * n + i] * half);
        let w2 = kick_spin(w, load3(3u * n + 3u * i), loads[6u * n + i], props[3u * n + i] * half);
        x += v * dt;
        put3(3u * n + 3u * i, v);
        put3(6u * n + 3u * i, w2);
        put3(3u * i, x);
    }
    let d = x - vec3<f64>(built[3u * i], built[3u * i + 1u], built[3u * i + 2u]);
    moved[i] = d.x * d.x + d.y * d.y + d.z * d.z;
    var out = 0u;
    if (param(4u) != 0.0lf) {
        let lo = param3(5u);
        let hi = param3(8u);
        if (any(x < lo) || any(x > hi)) {
            out = 1u;
        }
    }
    outside[i] = out;
}
