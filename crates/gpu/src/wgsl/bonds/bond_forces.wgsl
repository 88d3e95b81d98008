// Each intact bond's update for the step, with the arithmetic of the CPU's
// (dem::bond::kernel::update_bond) in the same order: its stored shear force and bending moment
// turned with it (the axis's own turn, then the pair's mean spin about the axis), the increments
// of its forces and moments from the spheres' relative motion at mid-step, the breakage test
// (tension first), and its output for the bond sums. A bond that breaks writes a zero output,
// records the step and its mid-point (the host logs it), and is not updated again.
//
// ends (u32, rows of BE_LEN), bond_props (BQ_), bond_params (BP_), bond_state (BS_),
// bond_output (BO_), broke (BB_): one row per bond (layout.rs).

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> params: array<f64>;
@group(0) @binding(3) var<storage, read> counts: array<u32>;
@group(0) @binding(4) var<storage, read_write> ends: array<u32>;
@group(0) @binding(5) var<storage, read> bond_props: array<f64>;
@group(0) @binding(6) var<storage, read> bond_params: array<f64>;
@group(0) @binding(7) var<storage, read_write> bond_state: array<f64>;
@group(0) @binding(8) var<storage, read_write> bond_output: array<f64>;
@group(0) @binding(9) var<storage, read_write> broke: array<f64>;
@group(0) @binding(10) var<storage, read_write> ctrl: array<atomic<u32>>;

const BOND_PI: f64 = 3.141592653589793lf;
const BOND_FRAC_1_PI: f64 = 0.3183098861837907lf;

fn state_at(k: u32) -> vec3<f64> {
    return vec3<f64>(bond_state[k], bond_state[k + 1u], bond_state[k + 2u]);
}

fn put_state(k: u32, v: vec3<f64>) {
    bond_state[k] = v.x;
    bond_state[k + 1u] = v.y;
    bond_state[k + 2u] = v.z;
}

fn put_output(k: u32, v: vec3<f64>) {
    bond_output[k] = v.x;
    bond_output[k + 1u] = v.y;
    bond_output[k + 2u] = v.z;
}

// (sin x, cos x): below 1e-2 rad (a bond's spin in a step is about 1e-7 rad) the CPU's series
// (kernel::small_angle_sin_cos); above it, which only a run that explodes reaches and WGSL has
// no f64 sine for, the series of x halved until it holds, doubled back.
fn bond_sin_cos(x: f64) -> vec2<f64> {
    var y = x;
    var halvings = 0;
    while (abs(y) >= 1e-2lf && halvings < 80) {
        y = 0.5lf * y;
        halvings++;
    }
    let y2 = y * y;
    var s = y * (1.0lf - y2 * (1.0lf / 6.0lf) * (1.0lf - y2 * (1.0lf / 20.0lf) * (1.0lf - y2 * (1.0lf / 42.0lf))));
    var c = 1.0lf - y2 * 0.5lf * (1.0lf - y2 * (1.0lf / 12.0lf) * (1.0lf - y2 * (1.0lf / 30.0lf)));
    for (var k = 0; k < halvings; k++) {
        let s2 = 2.0lf * s * c;
        c = c * c - s * s;
        s = s2;
    }
    return vec2<f64>(s, c);
}

// The rotation taking unit a to unit b (kernel::Turn), and its application to v.
struct Turn {
    cos: f64,
    sine_axis: vec3<f64>,
    scale: f64,
}

fn turn_of(a: vec3<f64>, b: vec3<f64>) -> Turn {
    let cos = dot3(a, b);
    let e = 1.0lf - cos;
    var scale: f64;
    if (abs(e) < 1e-4lf) {
        scale = 0.5lf * (1.0lf + 0.5lf * e * (1.0lf + 0.5lf * e * (1.0lf + 0.5lf * e * (1.0lf + 0.5lf * e))));
    } else {
        scale = 1.0lf / (1.0lf + cos);
    }
    return Turn(cos, cross3(a, b), scale);
}

fn turn_apply(t: Turn, v: vec3<f64>) -> vec3<f64> {
    if (t.cos > 1.0lf - 1e-15lf) {
        return v;
    }
    if (t.cos < -1.0lf + 1e-12lf) {
        return -v;
    }
    let k = t.sine_axis;
    return v * t.cos + cross3(k, v) + k * (dot3(k, v) * t.scale);
}

// A stored tangential vector turned with the bond: the axis's turn, the axial part dropped, then
// the mean spin about the new axis n.
fn follow(t: Turn, n: vec3<f64>, sc: vec2<f64>, v0: vec3<f64>) -> vec3<f64> {
    let v1 = turn_apply(t, v0);
    let v = v1 - n * dot3(v1, n);
    return v * sc.y + cross3(n, v) * sc.x;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = thread_index(gid);
    if (b >= counts[C_BONDS]) {
        return;
    }
    let e = BE_LEN * b;
    let i = ends[e + BE_FIRST];
    let j = ends[e + BE_SECOND];
    set_world(i);
    if (!stepping() || ends[e + BE_INTACT] == 0u) {
        return;
    }
    let n_all = counts[C_PARTICLES];
    let dt = param(P_DT);
    let delta = position(i) - position(j);
    let dist = sqrt(len2(delta));
    let n = delta * (1.0lf / dist);
    let wi = angular_velocity(i);
    let wj = angular_velocity(j);
    let sc = bond_sin_cos(0.5lf * dot3(wi + wj, n) * dt);
    let s = BS_LEN * b;
    let turn = turn_of(state_at(s + BS_AXIS), n);
    var shear = follow(turn, n, sc, state_at(s + BS_SHEAR_FORCE));
    var bending = follow(turn, n, sc, state_at(s + BS_BENDING));

    let ri = props[PR_RADIUS * n_all + i];
    let rj = props[PR_RADIUS * n_all + j];
    let share = dist * (1.0lf / (ri + rj));
    let ci = ri * share;
    let cj = rj * share;
    let v = velocity(i) - velocity(j);
    let vn = dot3(v, n);
    let vt = v - n * vn - cross3(wi * ci + wj * cj, n);
    let w = wi - wj;
    let wn = dot3(w, n);
    let wt = w - n * wn;

    // The bond's section (kernel::Section).
    let rb = bond_props[BQ_LEN * b + BQ_RADIUS];
    let rb2 = rb * rb;
    let polar = 0.5lf * BOND_PI * rb2 * rb2;
    let inv_rb = 1.0lf / rb;
    let inv_area = BOND_FRAC_1_PI * inv_rb * inv_rb;
    let area = BOND_PI * rb2;
    let inertia = 0.5lf * polar;
    let rb_over_polar = 2.0lf * inv_area * inv_rb;

    let kind = BP_LEN * ends[e + BE_KIND];
    let stiffness = bond_props[BQ_LEN * b + BQ_STIFFNESS];
    let k_n = bond_params[kind + BP_NORMAL_STIFFNESS] * stiffness;
    let k_t = bond_params[kind + BP_SHEAR_STIFFNESS] * stiffness;
    let normal = bond_state[s + BS_NORMAL_FORCE] - k_n * area * vn * dt;
    shear = shear - vt * (k_t * area * dt);
    let twist = bond_state[s + BS_TWIST] - k_t * polar * wn * dt;
    bending = bending - wt * (k_n * inertia * dt);
    bond_state[s + BS_NORMAL_FORCE] = normal;
    put_state(s + BS_SHEAR_FORCE, shear);
    bond_state[s + BS_TWIST] = twist;
    put_state(s + BS_BENDING, bending);
    put_state(s + BS_AXIS, n);

    // Breakage on squares, tension first (kernel::Section::breaks).
    let room_n = bond_params[kind + BP_CRITICAL_NORMAL_STRESS] + normal * inv_area;
    let bend = 2.0lf * rb_over_polar;
    var breaks = room_n <= 0.0lf || len2(bending) * (bend * bend) >= room_n * room_n;
    if (!breaks) {
        let room_t = bond_params[kind + BP_CRITICAL_SHEAR_STRESS] - abs(twist) * rb_over_polar;
        breaks = room_t <= 0.0lf || len2(shear) * (inv_area * inv_area) >= room_t * room_t;
    }
    let o = BO_LEN * b;
    if (breaks) {
        ends[e + BE_INTACT] = 0u;
        put_output(o + BO_FORCE, zero3());
        put_output(o + BO_TORQUE_FIRST, zero3());
        put_output(o + BO_TORQUE_SECOND, zero3());
        let r = BB_LEN * b;
        broke[r + BB_STEP] = f64(atomicLoad(&ctrl[K_STEPS_BEGUN]) - 1u);
        let mid = 0.5lf * (position(i) + position(j));
        broke[r + BB_POSITION] = mid.x;
        broke[r + BB_POSITION + 1u] = mid.y;
        broke[r + BB_POSITION + 2u] = mid.z;
        return;
    }
    let moment = n * twist + bending;
    let lever = cross3(n, shear);
    put_output(o + BO_FORCE, n * normal + shear);
    put_output(o + BO_TORQUE_FIRST, moment - lever * ci);
    put_output(o + BO_TORQUE_SECOND, -moment - lever * cj);
}
