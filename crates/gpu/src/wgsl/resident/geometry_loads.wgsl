// Each geometry's force and torque (about the origin) from its wall slots, summed in particle and
// slot order (Simulation::geometry_loads), once at the end of a run: a world that stopped earlier
// kept its rows and wall output from its last step.

@group(0) @binding(0) var<storage, read> dims: array<u32>;
@group(0) @binding(1) var<storage, read> rows: array<u32>;
@group(0) @binding(2) var<storage, read> cands: array<u32>;
@group(0) @binding(3) var<storage, read> output: array<f64>;
@group(0) @binding(4) var<storage, read_write> loads: array<f64>;
@group(0) @binding(5) var<storage, read> params: array<f64>;

fn out3(k: u32) -> vec3<f64> {
    return vec3<f64>(output[k], output[k + 1u], output[k + 2u]);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let g = gid.x;
    if (g >= dims[5]) {
        return;
    }
    var w = 0u;
    while (u32(params[PARAMS * w + P_END_GEOMETRY]) <= g) {
        w++;
    }
    let block = PARAMS * w;
    let n = dims[0];
    var f = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var t = f;
    for (var i = u32(params[block + P_FIRST_PARTICLE]); i < u32(params[block + P_END_PARTICLE]); i++) {
        for (var c = rows[4u * n + i]; c < rows[5u * n + i]; c++) {
            if (cands[2u * c] == g) {
                f += out3(10u * c);
                t += out3(10u * c + 3u);
            }
        }
    }
    loads[6u * g] = f.x;
    loads[6u * g + 1u] = f.y;
    loads[6u * g + 2u] = f.z;
    loads[6u * g + 3u] = t.x;
    loads[6u * g + 4u] = t.y;
    loads[6u * g + 5u] = t.z;
}
