// Each particle's new wall row: every element within reach (sim::walls::WallLists::rebuild), in
// geometry and element order, each with its history from the old row.

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read> props: array<f64>;
@group(0) @binding(3) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> dims: array<u32>;
@group(0) @binding(5) var<storage, read> search: array<f64>;
@group(0) @binding(6) var<storage, read> elements: array<f64>;
@group(0) @binding(7) var<storage, read> geoms: array<f64>;
@group(0) @binding(8) var<storage, read> old_cands: array<u32>;
@group(0) @binding(9) var<storage, read_write> new_cands: array<u32>;
@group(0) @binding(10) var<storage, read_write> rows: array<u32>;
@group(0) @binding(11) var<storage, read> params: array<f64>;


// After these: the old and the new wall histories, each in parts (`kernels::split_lists`).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[K_REBUILD]) == 0u) {
        return;
    }
    let i = thread_index(gid);
    let n = dims[D_PARTICLES];
    if (i >= n) {
        return;
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    set_world(i);
    if (!stepping()) {
        return;
    }
    let cap = dims[D_WALL_CAPACITY];
    let base = i * cap;
    let old_end = rows[R_WALL_END * n + i];
    let x = position(i);
    let reach = props[PR_RADIUS * n + i] + search[SE_WALL_REACH];
    let geometries = dims[D_GEOMETRIES];
    var count = 0u;
    var overflow = false;
    // Only the geometries of the particle's own world.
    for (var g = u32(param(P_FIRST_GEOMETRY)); g < u32(param(P_END_GEOMETRY)); g++) {
        let first = u32(geoms[G_LEN * g + G_FIRST_ELEMENT]);
        var last = dims[D_ELEMENTS];
        if (g + 1u < geometries) {
            last = u32(geoms[G_LEN * (g + 1u) + G_FIRST_ELEMENT]);
        }
        for (var e = 0u; e < last - first; e++) {
            let cl = closest(first + e, x, reach);
            if (!cl.found || cl.distance >= reach) {
                continue;
            }
            if (count == cap) {
                overflow = true;
                continue;
            }
            let c = base + count;
            new_cands[WC_LEN * c + WC_GEOMETRY] = g;
            new_cands[WC_LEN * c + WC_ELEMENT] = e;
            var found = EMPTY;
            for (var o = base; o < old_end; o++) {
                let same_geometry = old_cands[WC_LEN * o + WC_GEOMETRY] == g;
                if (same_geometry && old_cands[WC_LEN * o + WC_ELEMENT] == e) {
                    found = o;
                }
            }
            for (var h = 0u; h < H_LEN; h++) {
                var v = 0.0lf;
                if (found != EMPTY) {
                    v = old_history_get(H_LEN * found + h);
                }
                new_history_put(H_LEN * c + h, v);
            }
            count++;
        }
    }
    if (overflow) {
        atomicMax(&ctrl[K_OVERFLOW], OV_WALL_ROW);
    }
    rows[R_WALL_BEGIN * n + i] = base;
    rows[R_WALL_END * n + i] = base + count;
}
