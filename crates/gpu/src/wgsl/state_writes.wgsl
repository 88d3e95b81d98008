// Writes three consecutive numbers of `state` (bound read_write by the kernel).

fn put3(k: u32, v: vec3<f64>) {
    state[k] = v.x;
    state[k + 1u] = v.y;
    state[k + 2u] = v.z;
}
