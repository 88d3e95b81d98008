// Contacts of each particle with its geometry candidates (sim::walls::wall_contacts with
// Hertz-Mindlin, JKR down to its cut-off): face contacts first, then edge and vertex contacts that do not
// coincide with one already taken on the same geometry. One thread per particle walks its row.
//
// elements (E_), geoms (G_), cands (WC_), history (H_) and output (WO_) are rows; rows (R_) are
// blocks of N: a particle's candidates are R_WALL_BEGIN..R_WALL_END (layout.rs).
// status (u32, per particle): 1 when more contacts were taken than the kernel keeps (the host
//   redoes the stage on the CPU)

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> ints: array<u32>;
@group(0) @binding(3) var<storage, read> elements: array<f64>;
@group(0) @binding(4) var<storage, read> geoms: array<f64>;
@group(0) @binding(5) var<storage, read> cands: array<u32>;
@group(0) @binding(6) var<storage, read> rows: array<u32>;
@group(0) @binding(7) var<storage, read> table: array<f64>;
@group(0) @binding(8) var<storage, read> params: array<f64>;
@group(0) @binding(9) var<storage, read> counts: array<u32>;
@group(0) @binding(10) var<storage, read_write> status: array<u32>;

const KEEP: u32 = 32u;

fn clear(c: u32) {
    for (var k = 0u; k < H_LEN; k++) {
        history_put(H_LEN * c + k, 0.0lf);
    }
    for (var k = 0u; k < WO_LEN; k++) {
        output_put(WO_LEN * c + k, 0.0lf);
    }
}

// After these: `history` and `output`, the wall slots' histories and outputs, each whole or, in
// wall_forces_in_parts, in parts (`kernels::split_lists`).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[C_PARTICLES];
    if (i >= n) {
        return;
    }
    set_world(i);
    if (!stepping()) {
        return;
    }
    let w0 = rows[R_WALL_BEGIN * n + i];
    let w1 = rows[R_WALL_END * n + i];
    status[i] = 0u;
    if (w1 == w0) {
        return;
    }
    let x = position(i);
    let vel = velocity(i);
    let spin = angular_velocity(i);
    let r = props[PR_RADIUS * n + i];
    let m = props[PR_MASS * n + i];
    let material = ints[I_MATERIAL * n + i];
    let mats = u32(param(P_MATERIALS));
    let tol = 1.0e-9lf + 1.0e-6lf * r;
    var taken_cand: array<u32, KEEP>;
    var taken_point: array<vec3<f64>, KEEP>;
    var taken_feature: array<u32, KEEP>;
    var taken = 0u;
    for (var phase = FACE; phase <= EDGE; phase++) {
        for (var c = w0; c < w1; c++) {
            let g = cands[WC_LEN * c + WC_GEOMETRY];
            let first = u32(geoms[G_LEN * g + G_FIRST_ELEMENT]);
            let el = first + cands[WC_LEN * c + WC_ELEMENT];
            let wall_material = u32(geoms[G_LEN * g + G_MATERIAL]);
            let t = u32(param(P_TABLE)) + T_LEN * (material * mats + wall_material);
            // A cohesive contact reaches down to the law's cut-off (0 without a surface energy).
            let cutoff = cutoff_of(t, r);
            let cl = closest(el, x, r - cutoff);
            if (!cl.found) {
                if (phase == FACE) {
                    clear(c);
                }
                continue;
            }
            if (cl.feature != phase) {
                continue;
            }
            let d = r - cl.distance;
            var duplicate = false;
            if (d > cutoff) {
                for (var a = 0u; a < min(taken, KEEP); a++) {
                    let ca = taken_cand[a];
                    if (cands[WC_LEN * ca + WC_GEOMETRY] != g) {
                        continue;
                    }
                    if (phase == FACE || taken_feature[a] == EDGE) {
                        let dq = taken_point[a] - cl.point;
                        if (len2(dq) < tol * tol) {
                            duplicate = true;
                        }
                    } else {
                        let ea = first + cands[WC_LEN * ca + WC_ELEMENT];
                        if (distance_to(ea, cl.point) < tol) {
                            duplicate = true;
                        }
                    }
                    if (duplicate) {
                        break;
                    }
                }
            }
            if (d <= cutoff || duplicate) {
                clear(c);
                continue;
            }
            if (taken < KEEP) {
                taken_cand[taken] = c;
                taken_point[taken] = cl.point;
                taken_feature[taken] = phase;
            } else {
                status[i] = 1u;
            }
            taken++;

            let nrm = cl.normal;
            let ci = r - 0.5lf * d;
            let contact_point = x - ci * nrm;
            let lin = geom3(G_LEN * g + G_LINEAR_VELOCITY);
            let ang = geom3(G_LEN * g + G_ANGULAR_VELOCITY);
            let v_rel = vel - (lin + cross3(ang, contact_point));
            let hm = hertz_mindlin(
                t,
                nrm,
                d,
                r,
                m,
                v_rel,
                ci * spin,
                spin - ang,
                1.4lf * m * r * r,
                hist3(H_LEN * c + H_TANGENTIAL),
                hist3(H_LEN * c + H_ROLLING),
            );
            put_hist3(H_LEN * c + H_TANGENTIAL, hm.shear);
            put_hist3(H_LEN * c + H_ROLLING, hm.moment);
            let force = hm.force;
            let rolling_torque = hm.rolling_torque;
            let f_t = hm.tangential;
            let rolling_resistance = hm.rolling_resistance;
            let rolling_limit = rolling_resistance * ci;
            var reaction_rolling = -rolling_torque;
            if (rolling_limit > 0.0lf) {
                let s = sqrt(len2(spin));
                if (s > 0.0lf) {
                    reaction_rolling += spin * (rolling_limit / s);
                }
            }
            let o = WO_LEN * c;
            put_out3(o + WO_FORCE, -force);
            put_out3(o + WO_TORQUE, cross3(contact_point, -force) + reaction_rolling);
            put_out3(o + WO_PARTICLE_TORQUE, -ci * cross3(nrm, f_t) + rolling_torque);
            output_put(o + WO_ROLLING, rolling_limit);
        }
    }
}
