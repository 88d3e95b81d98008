// After the drift: a rebuild when a particle has moved half the skin since the last one; the
// first step in which a particle of a world is not finite or has left the domain (ctrl 8 + w); a
// particle that touched more walls than the wall kernel keeps in the step before. Worlds that are
// done are skipped; one whose steps just ended is checked once more (its last kick).

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read> moved: array<f64>;
@group(0) @binding(3) var<storage, read> outside: array<u32>;
@group(0) @binding(4) var<storage, read> status: array<u32>;
@group(0) @binding(5) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read> search: array<f64>;
@group(0) @binding(7) var<storage, read> props: array<f64>;
@group(0) @binding(8) var<storage, read> params: array<f64>;


fn finite(v: vec3<f64>) -> bool {
    let s = v.x + v.y + v.z;
    return s == s && abs(s) < 1.0e300lf;
}

fn position3(k: u32) -> vec3<f64> {
    return vec3<f64>(state[k], state[k + 1u], state[k + 2u]);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * counts[4];
    let n = counts[0];
    if (i >= n) {
        return;
    }
    let w = u32(props[4u * n + i]);
    let flag = params[PARAMS * w + P_STEPPING];
    if (flag == 0.0lf) {
        return;
    }
    if (moved[i] > search[3]) {
        atomicOr(&ctrl[1], 1u);
    }
    if (outside[i] != 0u || !finite(position3(3u * i)) || !finite(position3(3u * n + 3u * i))) {
        let last = u32(params[PARAMS * w + P_STEPS]) - 1u;
        atomicMin(&ctrl[8u + w], min(atomicLoad(&ctrl[0]) - 1u, last));
    }
    if (status[i] != 0u) {
        atomicMax(&ctrl[3], 5u);
    }
}
