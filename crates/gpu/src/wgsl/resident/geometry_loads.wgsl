// Each geometry's force and torque (about the origin) from its wall slots, summed in particle and
// slot order (Simulation::geometry_loads), once at the end of a run: a world that stopped earlier
// kept its rows and wall output from its last step.

@group(0) @binding(0) var<storage, read> dims: array<u32>;
@group(0) @binding(1) var<storage, read> rows: array<u32>;
@group(0) @binding(2) var<storage, read> cands: array<u32>;
@group(0) @binding(3) var<storage, read> output: array<f64>;
@group(0) @binding(4) var<storage, read_write> geometry_loads: array<f64>;
@group(0) @binding(5) var<storage, read> params: array<f64>;

fn out3(k: u32) -> vec3<f64> {
    return vec3<f64>(output[k], output[k + 1u], output[k + 2u]);
}

fn put_load3(k: u32, v: vec3<f64>) {
    geometry_loads[k] = v.x;
    geometry_loads[k + 1u] = v.y;
    geometry_loads[k + 2u] = v.z;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let g = gid.x;
    if (g >= dims[D_GEOMETRIES]) {
        return;
    }
    // The world of geometry g: the first whose geometries end after it.
    var w = 0u;
    while (u32(params[P_LEN * w + P_END_GEOMETRY]) <= g) {
        w++;
    }
    let block = P_LEN * w;
    let n = dims[D_PARTICLES];
    var f = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var t = f;
    let end = u32(params[block + P_END_PARTICLE]);
    for (var i = u32(params[block + P_FIRST_PARTICLE]); i < end; i++) {
        for (var c = rows[R_WALL_BEGIN * n + i]; c < rows[R_WALL_END * n + i]; c++) {
            if (cands[WC_LEN * c + WC_GEOMETRY] == g) {
                f += out3(WO_LEN * c + WO_FORCE);
                t += out3(WO_LEN * c + WO_TORQUE);
            }
        }
    }
    put_load3(GL_LEN * g + GL_FORCE, f);
    put_load3(GL_LEN * g + GL_TORQUE, t);
}
