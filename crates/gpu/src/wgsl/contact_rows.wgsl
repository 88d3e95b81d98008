// Accessors of the arrays the stage contact kernels (pair_forces, wall_forces) bind: `history`
// (rows of H_LEN) and `output`.

fn hist3(k: u32) -> vec3<f64> {
    return vec3<f64>(history[k], history[k + 1u], history[k + 2u]);
}

fn put_hist3(k: u32, v: vec3<f64>) {
    history[k] = v.x;
    history[k + 1u] = v.y;
    history[k + 2u] = v.z;
}

fn put_out3(k: u32, v: vec3<f64>) {
    output[k] = v.x;
    output[k + 1u] = v.y;
    output[k + 2u] = v.z;
}
