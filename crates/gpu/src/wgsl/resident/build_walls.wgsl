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
@group(0) @binding(9) var<storage, read> old_history: array<f64>;
@group(0) @binding(10) var<storage, read_write> new_cands: array<u32>;
@group(0) @binding(11) var<storage, read_write> new_history: array<f64>;
@group(0) @binding(12) var<storage, read_write> rows: array<u32>;
@group(0) @binding(13) var<storage, read> params: array<f64>;


fn position3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[1]) == 0u) {
        return;
    }
    let i = gid.x + gid.y * counts[4];
    let n = dims[0];
    if (i >= n) {
        return;
    }
    // A world that does not step keeps its rows (its last step's loads are read from them).
    if (params[PARAMS * u32(props[4u * n + i]) + P_STEPPING] != 1.0lf) {
        return;
    }
    let cap = dims[2];
    let base = i * cap;
    let old_end = rows[5u * n + i];
    let x = position3(3u * i);
    let reach = props[i] + search[2];
    let geometries = dims[5];
    // Only the geometries of the particle's own world.
    let world = PARAMS * u32(props[4u * n + i]);
    var count = 0u;
    var overflow = false;
    for (var g = u32(params[world + P_FIRST_GEOMETRY]); g < u32(params[world + P_END_GEOMETRY]); g++) {
        let first = u32(geoms[8u * g + 1u]);
        var last = dims[6];
        if (g + 1u < geometries) {
            last = u32(geoms[8u * (g + 1u) + 1u]);
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
            new_cands[2u * c] = g;
            new_cands[2u * c + 1u] = e;
            var found = EMPTY;
            for (var o = base; o < old_end; o++) {
                if (old_cands[2u * o] == g && old_cands[2u * o + 1u] == e) {
                    found = o;
                }
            }
            for (var h = 0u; h < 6u; h++) {
                var v = 0.0lf;
                if (found != EMPTY) {
                    v = old_history[6u * found + h];
                }
                new_history[6u * c + h] = v;
            }
            count++;
        }
    }
    if (overflow) {
        atomicMax(&ctrl[3], 4u);
    }
    rows[4u * n + i] = base;
    rows[5u * n + i] = base + count;
}
