// Contacts of each particle with its geometry candidates (sim::walls::wall_contacts with
// Hertz-Mindlin, JKR down to its cut-off): face contacts first, then edge and vertex contacts that do not
// coincide with one already taken on the same geometry. One thread per particle walks its row.
//
// elements (16 each): kind (0 plane, 1 rect, 2 disc, 3 cylinder shell, 4 triangle), then
//   plane: point, normal | rect: centre, normal, u, v, half u, half v | disc: centre, normal,
//   radius | cylinder: base, axis, radius, length | triangle: a, b, c
// geoms (8 each): material, first element, linear velocity xyz, angular velocity xyz
// cands (u32, 2 each): geometry, element (within the geometry)
// history (6 each), output (10 each): force on the geometry xyz, torque on the geometry about the
//   origin xyz, torque on the particle xyz, rolling torque limit
// status (u32, per particle): 1 when more contacts were taken than the kernel keeps (the host
//   redoes the stage on the CPU)

@group(0) @binding(0) var<storage, read> state: array<f64>;
@group(0) @binding(1) var<storage, read> props: array<f64>;
@group(0) @binding(2) var<storage, read> ints: array<u32>;
@group(0) @binding(3) var<storage, read> elements: array<f64>;
@group(0) @binding(4) var<storage, read> geoms: array<f64>;
@group(0) @binding(5) var<storage, read> cands: array<u32>;
@group(0) @binding(6) var<storage, read> starts: array<u32>;
@group(0) @binding(7) var<storage, read_write> history: array<f64>;
@group(0) @binding(8) var<storage, read_write> output: array<f64>;
@group(0) @binding(9) var<storage, read> table: array<f64>;
@group(0) @binding(10) var<storage, read> params: array<f64>;
@group(0) @binding(11) var<storage, read> counts: array<u32>;
@group(0) @binding(12) var<storage, read_write> status: array<u32>;

const FACE: u32 = 0u;
const EDGE: u32 = 1u;
const KEEP: u32 = 32u;

struct Closest {
    found: bool,
    point: vec3<f64>,
    normal: vec3<f64>,
    distance: f64,
    feature: u32,
}

fn el3(k: u32) -> vec3<f64> {
    return vec3<f64>(elements[k], elements[k + 1u], elements[k + 2u]);
}

fn geom3(k: u32) -> vec3<f64> {
    return vec3<f64>(geoms[k], geoms[k + 1u], geoms[k + 2u]);
}

fn none() -> Closest {
    return Closest(false, zero3(), zero3(), 0.0lf, FACE);
}

fn from_vector(point: vec3<f64>, x: vec3<f64>, feature: u32) -> Closest {
    let d = x - point;
    let dist = sqrt(len2(d));
    if (dist <= 0.0lf) {
        return none();
    }
    return Closest(true, point, d / dist, dist, feature);
}

fn face(point: vec3<f64>, normal: vec3<f64>, s: f64) -> Closest {
    var side = -1.0lf;
    if (s >= 0.0lf) {
        side = 1.0lf;
    }
    return Closest(true, point, side * normal, abs(s), FACE);
}

fn triangle(a: vec3<f64>, b: vec3<f64>, c: vec3<f64>, x: vec3<f64>) -> Closest {
    let ab = b - a;
    let ac = c - a;
    let ap = x - a;
    let d1 = dot3(ab, ap);
    let d2 = dot3(ac, ap);
    if (d1 <= 0.0lf && d2 <= 0.0lf) {
        return from_vector(a, x, EDGE);
    }
    let bp = x - b;
    let d3 = dot3(ab, bp);
    let d4 = dot3(ac, bp);
    if (d3 >= 0.0lf && d4 <= d3) {
        return from_vector(b, x, EDGE);
    }
    let vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0lf && d1 >= 0.0lf && d3 <= 0.0lf) {
        let t = d1 / (d1 - d3);
        return from_vector(a + t * ab, x, EDGE);
    }
    let cp = x - c;
    let d5 = dot3(ab, cp);
    let d6 = dot3(ac, cp);
    if (d6 >= 0.0lf && d5 <= d6) {
        return from_vector(c, x, EDGE);
    }
    let vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0lf && d2 >= 0.0lf && d6 <= 0.0lf) {
        let t = d2 / (d2 - d6);
        return from_vector(a + t * ac, x, EDGE);
    }
    let va = d3 * d6 - d5 * d4;
    if (va <= 0.0lf && (d4 - d3) >= 0.0lf && (d5 - d6) >= 0.0lf) {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return from_vector(b + t * (c - b), x, EDGE);
    }
    let denom = 1.0lf / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    let q = a + ab * v + ac * w;
    let cr = cross3(ab, ac);
    let nrm = cr * (1.0lf / sqrt(len2(cr)));
    let s = dot3(x - q, nrm);
    return face(q, nrm, s);
}

// Element::closest: the closest point of element e to x, or none behind a one-sided plane by
// more than `reach` or exactly on a surface.
fn closest(e: u32, x: vec3<f64>, reach: f64) -> Closest {
    let k = 16u * e;
    let kind = u32(elements[k]);
    if (kind == 0u) {
        let point = el3(k + 1u);
        let normal = el3(k + 4u);
        let s = dot3(x - point, normal);
        if (s < -reach) {
            return none();
        }
        return Closest(true, x - s * normal, normal, s, FACE);
    }
    if (kind == 1u) {
        let center = el3(k + 1u);
        let normal = el3(k + 4u);
        let u = el3(k + 7u);
        let v = el3(k + 10u);
        let half_u = elements[k + 13u];
        let half_v = elements[k + 14u];
        let r = x - center;
        let pu = dot3(r, u);
        let pv = dot3(r, v);
        let s = dot3(r, normal);
        if (abs(pu) <= half_u && abs(pv) <= half_v) {
            return face(x - s * normal, normal, s);
        }
        let q = center + clamp(pu, -half_u, half_u) * u + clamp(pv, -half_v, half_v) * v;
        return from_vector(q, x, EDGE);
    }
    if (kind == 2u) {
        let center = el3(k + 1u);
        let normal = el3(k + 4u);
        let radius = elements[k + 7u];
        let r = x - center;
        let s = dot3(r, normal);
        let inplane = r - s * normal;
        let rho = sqrt(len2(inplane));
        if (rho <= radius) {
            return face(x - s * normal, normal, s);
        }
        return from_vector(center + inplane * (radius / rho), x, EDGE);
    }
    if (kind == 3u) {
        let base = el3(k + 1u);
        let axis = el3(k + 4u);
        let radius = elements[k + 7u];
        let length = elements[k + 8u];
        let r = x - base;
        let h = dot3(r, axis);
        let radial = r - h * axis;
        let rho = sqrt(len2(radial));
        if (rho <= 0.0lf) {
            return none();
        }
        let e = radial / rho;
        if (h >= 0.0lf && h <= length) {
            var side = -1.0lf;
            if (rho >= radius) {
                side = 1.0lf;
            }
            return Closest(true, base + h * axis + radius * e, side * e, abs(rho - radius), FACE);
        }
        let q = base + clamp(h, 0.0lf, length) * axis + radius * e;
        return from_vector(q, x, EDGE);
    }
    return triangle(el3(k + 1u), el3(k + 4u), el3(k + 7u), x);
}

fn distance_to(e: u32, q: vec3<f64>) -> f64 {
    let c = closest(e, q, 1.0e300lf);
    if (!c.found) {
        return 0.0lf;
    }
    return abs(c.distance);
}

fn clear(c: u32) {
    for (var k = 0u; k < 6u; k++) {
        history[6u * c + k] = 0.0lf;
    }
    for (var k = 0u; k < 10u; k++) {
        output[10u * c + k] = 0.0lf;
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_index(gid);
    let n = counts[0];
    if (i >= n) {
        return;
    }
    let w0 = starts[i];
    let w1 = starts[i + 1u];
    status[i] = 0u;
    if (w1 == w0) {
        return;
    }
    let x = get3(3u * i);
    let vel = get3(3u * n + 3u * i);
    let spin = get3(6u * n + 3u * i);
    let r = props[i];
    let m = props[n + i];
    let material = ints[i];
    let mats = u32(params[15]);
    let tol = 1.0e-9lf + 1.0e-6lf * r;
    var taken_cand: array<u32, KEEP>;
    var taken_point: array<vec3<f64>, KEEP>;
    var taken_feature: array<u32, KEEP>;
    var taken = 0u;
    for (var phase = FACE; phase <= EDGE; phase++) {
        for (var c = w0; c < w1; c++) {
            let g = cands[2u * c];
            let el = u32(geoms[8u * g + 1u]) + cands[2u * c + 1u];
            let t = 7u * (material * mats + u32(geoms[8u * g]));
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
                    if (cands[2u * ca] != g) {
                        continue;
                    }
                    if (phase == FACE || taken_feature[a] == EDGE) {
                        let dq = taken_point[a] - cl.point;
                        if (len2(dq) < tol * tol) {
                            duplicate = true;
                        }
                    } else {
                        let ea = u32(geoms[8u * g + 1u]) + cands[2u * ca + 1u];
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
            let lin = geom3(8u * g + 2u);
            let ang = geom3(8u * g + 5u);
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
                hist3(6u * c),
                hist3(6u * c + 3u),
            );
            put_hist3(6u * c, hm.shear);
            put_hist3(6u * c + 3u, hm.moment);
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
            put_out3(10u * c, -force);
            put_out3(10u * c + 3u, cross3(contact_point, -force) + reaction_rolling);
            put_out3(10u * c + 6u, -ci * cross3(nrm, f_t) + rolling_torque);
            output[10u * c + 9u] = rolling_limit;
        }
    }
}
