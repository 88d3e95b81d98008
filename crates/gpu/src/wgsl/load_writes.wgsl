// Writes three consecutive numbers of `loads` (bound read_write by the kernel).

fn put_load3(k: u32, v: vec3<f64>) {
    loads[k] = v.x;
    loads[k + 1u] = v.y;
    loads[k + 2u] = v.z;
}
