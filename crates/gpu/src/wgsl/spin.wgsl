// The half kick of the spin with the constant-directional rolling torque applied implicitly
// (cpu::kick_spin): it opposes the spin and can at most bring it to rest.
fn kick_spin(w: vec3<f64>, torque: vec3<f64>, limit: f64, k: f64) -> vec3<f64> {
    let w1 = w + torque * k;
    if (limit <= 0.0lf) {
        return w1;
    }
    let brake = limit * k;
    let s2 = w1.x * w1.x + w1.y * w1.y + w1.z * w1.z;
    if (s2 <= brake * brake) {
        return vec3<f64>(0.0lf, 0.0lf, 0.0lf);
    }
    return w1 * (1.0lf - brake / sqrt(s2));
}
