// Reads three consecutive numbers of `loads` (bound by the kernel).

fn load3(k: u32) -> vec3<f64> {
    return vec3<f64>(loads[k], loads[k + 1u], loads[k + 2u]);
}
