// Half kick and drift of every free sphere (CpuBackend::integrate), and each particle's squared
// displacement since the last list build. The host finds the largest, and the first particle that
// is not finite or has left the domain (flag 1).
//
// state (S_), loads (L_), props (PR_): blocks of N (layout.rs); built: positions at the last
// build, 3 numbers a particle.

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> built: array<f64>;
@group(0) @binding(5) var<storage, read> params: array<f64>;
@group(0) @binding(6) var<storage, read> counts: array<u32>;
@group(0) @binding(7) var<storage, read_write> moved: array<f64>;
@group(0) @binding(8) var<storage, read_write> outside: array<u32>;

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
    let dt = param(P_DT);
    let half = 0.5lf * dt;
    var x = position(i);
    if (param(P_CLUMPS) == 0.0lf || body[i] == NO_BODY) {
        var v = velocity(i);
        let w = angular_velocity(i);
        v += load3(L_FORCE * n + 3u * i) * (props[PR_INV_MASS * n + i] * half);
        let w2 = kick_spin(
            w,
            load3(L_TORQUE * n + 3u * i),
            loads[L_ROLLING_LIMIT * n + i],
            props[PR_INV_INERTIA * n + i] * half,
        );
        x += v * dt;
        put3(S_VELOCITY * n + 3u * i, v);
        put3(S_ANGULAR_VELOCITY * n + 3u * i, w2);
        put3(S_POSITION * n + 3u * i, x);
    }
    let d = x - vec3<f64>(built[3u * i], built[3u * i + 1u], built[3u * i + 2u]);
    moved[i] = d.x * d.x + d.y * d.y + d.z * d.z;
    var out = 0u;
    if (param(P_HAS_DOMAIN) != 0.0lf) {
        let lo = param3(P_DOMAIN_LOW);
        let hi = param3(P_DOMAIN_HIGH);
        if (any(x < lo) || any(x > hi)) {
            out = 1u;
        }
    }
    outside[i] = out;
}
