// Each particle sums gravity, its pair slots (as i and as j) and its wall slots in a fixed order
// into its force, torque and rolling torque limit; with the kick flag, free spheres get the second
// half kick (CpuBackend::particle_sums).
//
// csr (u32): pair row starts N+1 | reverse row starts N+1 | reverse entries R | wall row starts N+1
// walls (per candidate, 7): force on the geometry xyz, torque on the particle xyz, rolling

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read_write> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> pairs: array<f64>;
@group(0) @binding(5) var<storage, read> csr: array<u32>;
@group(0) @binding(6) var<storage, read> walls: array<f64>;
@group(0) @binding(7) var<storage, read> params: array<f64>;
@group(0) @binding(8) var<storage, read> counts: array<u32>;

fn pair3(k: u32) -> vec3<f64> {
    return vec3<f64>(pairs[k], pairs[k + 1u], pairs[k + 2u]);
}

fn wall3(k: u32) -> vec3<f64> {
    return vec3<f64>(walls[k], walls[k + 1u], walls[k + 2u]);
}

fn put3(k: u32, v: vec3<f64>) {
    state[k] = v.x;
    state[k + 1u] = v.y;
    state[k + 2u] = v.z;
}

fn put_load3(k: u32, v: vec3<f64>) {
    loads[k] = v.x;
    loads[k + 1u] = v.y;
    loads[k + 2u] = v.z;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[0];
    if (i >= n) {
        return;
    }
    var f = param3(1u) * props[n + i];
    var t = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var lim = 0.0lf;
    for (var q = csr[i]; q < csr[i + 1u]; q++) {
        f += pair3(11u * q);
        t += pair3(11u * q + 3u);
        lim += pairs[11u * q + 9u];
    }
    let rev = 2u * (n + 1u);
    for (var k = csr[n + 1u + i]; k < csr[n + 1u + i + 1u]; k++) {
        let q = csr[rev + k];
        f -= pair3(11u * q);
        t += pair3(11u * q + 6u);
        lim += pairs[11u * q + 10u];
    }
    let ws = rev + counts[2];
    for (var c = csr[ws + i]; c < csr[ws + i + 1u]; c++) {
        f -= wall3(7u * c);
        t += wall3(7u * c + 3u);
        lim += walls[7u * c + 6u];
    }
    put_load3(3u * i, f);
    put_load3(3u * n + 3u * i, t);
    loads[6u * n + i] = lim;
    if (params[12] != 0.0lf && (params[11] == 0.0lf || body[i] == NO_BODY)) {
        let half = 0.5lf * params[0];
        let v = get3(3u * n + 3u * i) + f * (props[2u * n + i] * half);
        let w = kick_spin(get3(6u * n + 3u * i), t, lim, props[3u * n + i] * half);
        put3(3u * n + 3u * i, v);
        put3(6u * n + 3u * i, w);
    }
}
