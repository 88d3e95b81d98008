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
@group(0) @binding(9) var<storage, read_write> new_ij: array<u32>;
@group(0) @binding(10) var<storage, read_write> rows: array<u32>;
@group(0) @binding(11) var<storage, read_write> reverse_count: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> built: array<f64>;
@group(0) @binding(13) var<storage, read> params: array<f64>;

// After these: the pair histories' halves (the old histories are the current half,
// history_halves.wgsl) and the new histories, each in parts (`kernels::split_lists`).

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
    let cap = dims[D_PAIR_CAPACITY];
    let per_bucket = dims[D_BUCKET_CAPACITY];
    let base = i * cap;
    let x = position(i);
    let ri = props[PR_RADIUS * n + i];
    let reach = search[SE_PAIR_REACH];
    let home = cell_of(x, search[SE_INV_CELL]);
    let world = props[PR_WORLD * n + i];
    var seen: array<u32, 27>;
    var buckets_seen = 0u;
    var count = 0u;
    var overflow = false;
    for (var dz = -1; dz <= 1; dz++) {
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let b = bucket_of(home + vec3<i32>(dx, dy, dz), u32(world), dims[D_BUCKETS]);
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
                    if (j <= i || props[PR_WORLD * n + j] != world) {
                        continue;
                    }
                    let cut = ri + props[PR_RADIUS * n + j] + reach;
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
                    while (k > 0u && new_ij[IJ_LEN * (base + k - 1u) + IJ_J] > j) {
                        new_ij[IJ_LEN * (base + k) + IJ_J] = new_ij[IJ_LEN * (base + k - 1u) + IJ_J];
                        k--;
                    }
                    new_ij[IJ_LEN * (base + k) + IJ_J] = j;
                    count++;
                }
            }
        }
    }
    if (overflow) {
        atomicMax(&ctrl[K_OVERFLOW], OV_PAIR_ROW);
    }
    let old_end = rows[R_PAIR_END * n + i];
    var o = base;
    let half = history_half();
    for (var k = 0u; k < count; k++) {
        let q = base + k;
        let j = new_ij[IJ_LEN * q + IJ_J];
        new_ij[IJ_LEN * q + IJ_I] = i;
        while (o < old_end && old_ij[IJ_LEN * o + IJ_J] < j) {
            o++;
        }
        let carried = o < old_end && old_ij[IJ_LEN * o + IJ_J] == j;
        for (var h = 0u; h < H_LEN; h++) {
            var v = 0.0lf;
            if (carried) {
                v = half_get(half, H_LEN * o + h);
            }
            new_pair_history_put(H_LEN * q + h, v);
        }
        let r = atomicAdd(&reverse_count[j], 1u);
        if (r < cap) {
            rows[R_REVERSE_ENTRIES * n + j * cap + r] = q;
        } else {
            atomicMax(&ctrl[K_OVERFLOW], OV_REVERSE_ROW);
        }
    }
    for (var k = count; k < cap; k++) {
        new_ij[IJ_LEN * (base + k) + IJ_I] = EMPTY;
        new_ij[IJ_LEN * (base + k) + IJ_J] = EMPTY;
    }
    rows[R_PAIR_BEGIN * n + i] = base;
    rows[R_PAIR_END * n + i] = base + count;
    built[3u * i] = x.x;
    built[3u * i + 1u] = x.y;
    built[3u * i + 2u] = x.z;
}
