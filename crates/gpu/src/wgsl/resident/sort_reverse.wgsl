// Each particle's reverse row (the slots of the pairs in which it is j) sorted, so that the
// particle sums add them in a fixed order.

@group(0) @binding(0) var<storage, read> counts: array<u32>;
@group(0) @binding(1) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> rows: array<u32>;
@group(0) @binding(3) var<storage, read> reverse_count: array<u32>;
@group(0) @binding(4) var<storage, read> dims: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (atomicLoad(&ctrl[1]) == 0u) {
        return;
    }
    let j = gid.x + gid.y * counts[4];
    let n = dims[0];
    if (j >= n) {
        return;
    }
    let cap = dims[1];
    let m = min(reverse_count[j], cap);
    let base = 6u * n + j * cap;
    for (var a = 1u; a < m; a++) {
        let v = rows[base + a];
        var k = a;
        while (k > 0u && rows[base + k - 1u] > v) {
            rows[base + k] = rows[base + k - 1u];
            k--;
        }
        rows[base + k] = v;
    }
    rows[2u * n + j] = j * cap;
    rows[3u * n + j] = j * cap + m;
}
