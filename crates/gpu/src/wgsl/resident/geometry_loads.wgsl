// Each geometry's force and torque (about the origin) from its wall slots (Simulation::
// geometry_loads), once at the end of a run: a world that stopped earlier kept its rows and wall
// output from its last step. One workgroup a geometry: its threads take the world's particles in
// turn (thread k the k-th, the 64 + k-th, ... from the world's first), each summing its particles'
// slots in order, then the 64 partial sums are added in a fixed tree. The order depends only on
// the world's own particles, so a world's loads are the same alone or in a batch and run to run;
// against the CPU's sum (fixed chunks of wall slots, added in chunk order) they differ by
// round-off.

@group(0) @binding(0) var<storage, read> dims: array<u32>;
@group(0) @binding(1) var<storage, read> rows: array<u32>;
@group(0) @binding(2) var<storage, read> cands: array<u32>;
@group(0) @binding(3) var<storage, read_write> geometry_loads: array<f64>;
@group(0) @binding(4) var<storage, read> params: array<f64>;

// The host launches WORKGROUP (lib.rs) threads a geometry.
const LOAD_THREADS = 64;

var<workgroup> part_force: array<vec3<f64>, LOAD_THREADS>;
var<workgroup> part_torque: array<vec3<f64>, LOAD_THREADS>;

fn out3(k: u32) -> vec3<f64> {
    return vec3<f64>(output_get(k), output_get(k + 1u), output_get(k + 2u));
}

fn put_load3(k: u32, v: vec3<f64>) {
    geometry_loads[k] = v.x;
    geometry_loads[k + 1u] = v.y;
    geometry_loads[k + 2u] = v.z;
}

// After these: `output`, the wall outputs, in parts (`kernels::split_lists`).

@compute @workgroup_size(LOAD_THREADS)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let g = wid.x + wid.y * groups.x;
    // Not a return: every thread of the workgroup reaches the barriers.
    let mine = g < dims[D_GEOMETRIES];
    var f = vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    var t = f;
    if (mine) {
        // The world of geometry g: the first whose geometries end after it.
        var w = 0u;
        while (u32(params[P_LEN * w + P_END_GEOMETRY]) <= g) {
            w++;
        }
        let block = P_LEN * w;
        let n = dims[D_PARTICLES];
        let end = u32(params[block + P_END_PARTICLE]);
        for (var i = u32(params[block + P_FIRST_PARTICLE]) + lid; i < end; i += u32(LOAD_THREADS)) {
            for (var c = rows[R_WALL_BEGIN * n + i]; c < rows[R_WALL_END * n + i]; c++) {
                if (cands[WC_LEN * c + WC_GEOMETRY] == g) {
                    f += out3(WO_LEN * c + WO_FORCE);
                    t += out3(WO_LEN * c + WO_TORQUE);
                }
            }
        }
    }
    part_force[lid] = f;
    part_torque[lid] = t;
    workgroupBarrier();
    for (var half: u32 = LOAD_THREADS / 2; half > 0u; half = half >> 1u) {
        if (lid < half) {
            part_force[lid] += part_force[lid + half];
            part_torque[lid] += part_torque[lid + half];
        }
        workgroupBarrier();
    }
    // Thread 0 holds the sum.
    if (mine && lid == 0u) {
        put_load3(GL_LEN * g + GL_FORCE, part_force[lid]);
        put_load3(GL_LEN * g + GL_TORQUE, part_torque[lid]);
    }
}
