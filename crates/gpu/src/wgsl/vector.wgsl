// Vector helpers, shared by every kernel (they bind nothing), written out in glam's order of
// operations so that results match the CPU's.
fn len2(v: vec3<f64>) -> f64 {
    return v.x * v.x + v.y * v.y + v.z * v.z;
}

fn dot3(a: vec3<f64>, b: vec3<f64>) -> f64 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

fn zero3() -> vec3<f64> {
    return vec3<f64>(0.0lf, 0.0lf, 0.0lf);
}
