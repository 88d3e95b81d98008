// Each particle's reverse row (the slots of the pairs in which it is j) sorted, so that the
// particle sums add them in a fixed order.

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> rows: array<u32>;
@group(0) @binding(3) var<storage, read> reverse_count: array<u32>;
@group(0) @binding(4) var<storage, read> dims: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[K_REBUILD]) == 0u) {
        return;
    }
    let j = gid.x + gid.y * counts[C_ROW_WIDTH];
    let n = dims[D_PARTICLES];
    if (j >= n) {
        return;
    }
    // A reverse row has the pair rows' capacity.
    let cap = dims[D_PAIR_CAPACITY];
    let m = min(reverse_count[j], cap);
    let base = R_REVERSE_ENTRIES * n + j * cap;
    for (var a = 1u; a < m; a++) {
        let v = rows[base + a];
        var k = a;
        while (k > 0u && rows[base + k - 1u] > v) {
            rows[base + k] = rows[base + k - 1u];
            k--;
        }
        rows[base + k] = v;
    }
    rows[R_REVERSE_BEGIN * n + j] = j * cap;
    rows[R_REVERSE_END * n + j] = j * cap + m;
}
