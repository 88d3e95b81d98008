// Each particle's new pair row: every j > i within reach in the 27 cells around it, sorted by j,
// each with its history from the old row (a merge: both are sorted); the reverse rows get the
// new slots; the positions are kept for the next displacement check.

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> counts: array<u32>;
@group(0) @binding(3) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> bucket_count: array<u32>;
@group(0) @binding(5) var<storage, read> bucket_items: array<u32>;
@group(0) @binding(6) var<storage, read> dims: array<u32>;
@group(0) @binding(7) var<storage, read> search: array<f64>;
@group(0) @binding(8) var<storage, read> old_ij: array<u32>;
@group(0) @binding(9) var<storage, read> old_history: array<f64>;
@group(0) @binding(10) var<storage, read_write> new_ij: array<u32>;
@group(0) @binding(11) var<storage, read_write> new_history: array<f64>;
@group(0) @binding(12) var<storage, read_write> rows: array<u32>;
@group(0) @binding(13) var<storage, read_write> reverse_count: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read_write> built: array<f64>;
@group(0) @binding(15) var<storage, read> params: array<f64>;

fn position(i: u32) -> vec3<f64> {
    return vec3<f64>(state[3u * i], state[3u * i + 1u], state[3u * i + 2u]);
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
    let cap = dims[1];
    let per_bucket = dims[4];
    let base = i * cap;
    let x = position(i);
    let ri = props[i];
    let reach = search[1];
    let home = cell_of(x, search[0]);
    let world = props[4u * n + i];
    var seen: array<u32, 27>;
    var buckets_seen = 0u;
    var count = 0u;
    var overflow = false;
    for (var dz = -1; dz <= 1; dz++) {
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let b = bucket_of(home + vec3<i32>(dx, dy, dz), u32(world), dims[3]);
                // Two cells may share a bucket: visit it once.
                var again = false;
                for (var k = 0u; k < buckets_seen; k++) {
                    if (seen[k] == b) {
                        again = true;
                    }
                }
                if (again) {
                    continue;
                }
                seen[buckets_seen] = b;
                buckets_seen++;
                let m = min(bucket_count[b], per_bucket);
                for (var s = 0u; s < m; s++) {
                    let j = bucket_items[b * per_bucket + s];
                    if (j <= i || props[4u * n + j] != world) {
                        continue;
                    }
                    let cut = ri + props[j] + reach;
                    let d = position(j) - x;
                    if (d.x * d.x + d.y * d.y + d.z * d.z >= cut * cut) {
                        continue;
                    }
                    if (count == cap) {
                        overflow = true;
                        continue;
                    }
                    // Insertion into the row, kept sorted by j.
                    var k = count;
                    while (k > 0u && new_ij[2u * (base + k - 1u) + 1u] > j) {
                        new_ij[2u * (base + k) + 1u] = new_ij[2u * (base + k - 1u) + 1u];
                        k--;
                    }
                    new_ij[2u * (base + k) + 1u] = j;
                    count++;
                }
            }
        }
    }
    if (overflow) {
        atomicMax(&ctrl[3], 2u);
    }
    let old_end = rows[n + i];
    var o = base;
    for (var k = 0u; k < count; k++) {
        let q = base + k;
        let j = new_ij[2u * q + 1u];
        new_ij[2u * q] = i;
        while (o < old_end && old_ij[2u * o + 1u] < j) {
            o++;
        }
        let carried = o < old_end && old_ij[2u * o + 1u] == j;
        for (var h = 0u; h < 6u; h++) {
            var v = 0.0lf;
            if (carried) {
                v = old_history[6u * o + h];
            }
            new_history[6u * q + h] = v;
        }
        let r = atomicAdd(&reverse_count[j], 1u);
        if (r < cap) {
            rows[6u * n + j * cap + r] = q;
        } else {
            atomicMax(&ctrl[3], 3u);
        }
    }
    for (var k = count; k < cap; k++) {
        new_ij[2u * (base + k)] = EMPTY;
        new_ij[2u * (base + k) + 1u] = EMPTY;
    }
    rows[i] = base;
    rows[n + i] = base + count;
    built[3u * i] = x.x;
    built[3u * i + 1u] = x.y;
    built[3u * i + 2u] = x.z;
}
