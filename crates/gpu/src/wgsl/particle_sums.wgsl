// Each particle sums gravity, its pair slots (as i and as j) and its wall slots in a fixed order
// into its force, torque and rolling torque limit; with the kick flag, free spheres get the second
// half kick (CpuBackend::particle_sums).
//
// rows (u32): pair begin N | pair end N | reverse begin N | reverse end N | wall begin N |
//   wall end N | reverse entries (pair slots); rows may have gaps between them (the resident
//   steps keep a fixed capacity per particle)
// walls (per candidate, 10): the wall kernel's output (wall_forces.wgsl)

@group(0) @binding(0) var<storage, read_write> state: array<f64>;
@group(0) @binding(1) var<storage, read_write> loads: array<f64>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read> body: array<u32>;
@group(0) @binding(4) var<storage, read> pairs: array<f64>;
@group(0) @binding(5) var<storage, read> rows: array<u32>;
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
    set_world(i);
    if (!stepping()) {
        return;
    }
    var f = param3(1u) * props[n + i];
    var t = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var lim = 0.0lf;
    for (var q = rows[i]; q < rows[n + i]; q++) {
        f += pair3(11u * q);
        t += pair3(11u * q + 3u);
        lim += pairs[11u * q + 9u];
    }
    for (var k = rows[2u * n + i]; k < rows[3u * n + i]; k++) {
        let q = rows[6u * n + k];
        f -= pair3(11u * q);
        t += pair3(11u * q + 6u);
        lim += pairs[11u * q + 10u];
    }
    for (var c = rows[4u * n + i]; c < rows[5u * n + i]; c++) {
        f -= wall3(10u * c);
        t += wall3(10u * c + 6u);
        lim += walls[10u * c + 9u];
    }
    put_load3(3u * i, f);
    put_load3(3u * n + 3u * i, t);
    loads[6u * n + i] = lim;
    if (param(12u) != 0.0lf && (param(11u) == 0.0lf || body[i] == NO_BODY)) {
        let half = 0.5lf * param(0u);
        let v = get3(3u * n + 3u * i) + f * (props[2u * n + i] * half);
        let w = kick_spin(get3(6u * n + 3u * i), t, lim, props[3u * n + i] * half);
        put3(3u * n + 3u * i, v);
        put3(6u * n + 3u * i, w);
    }
}
