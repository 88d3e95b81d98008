// Accessors of the lists the stage contact kernels (pair_forces, wall_forces) bind through
// `kernels::split_lists` (whole, or in parts in wall_forces_in_parts): `history` (rows of H_LEN)
// and `output`.

fn hist3(k: u32) -> vec3<f64> {
    return vec3<f64>(history_get(k), history_get(k + 1u), history_get(k + 2u));
}

fn put_hist3(k: u32, v: vec3<f64>) {
    for (var d = 0; d < 3; d++) {
        history_put(k + u32(d), v[d]);
    }
}

fn put_out3(k: u32, v: vec3<f64>) {
    for (var d = 0; d < 3; d++) {
        output_put(k + u32(d), v[d]);
    }
}
