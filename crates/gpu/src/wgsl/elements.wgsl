// The closest point of a geometry element to a sphere centre (dem::geometry::Element::closest),
// shared by the wall contacts and the wall-candidate search of the device-resident steps.
//
// elements: rows of E_LEN, the kind (an EK_ code) at E_KIND and that kind's fields (E_PLANE_*,
// E_RECT_*, ...; layout.rs says what each holds); geoms: rows of G_LEN.

const FACE: u32 = 0u;
const EDGE: u32 = 1u;

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
    let k = E_LEN * e;
    let kind = u32(elements[k + E_KIND]);
    if (kind == EK_PLANE) {
        let point = el3(k + E_PLANE_POINT);
        let normal = el3(k + E_PLANE_NORMAL);
        let s = dot3(x - point, normal);
        if (s < -reach) {
            return none();
        }
        return Closest(true, x - s * normal, normal, s, FACE);
    }
    if (kind == EK_RECT) {
        let center = el3(k + E_RECT_CENTER);
        let normal = el3(k + E_RECT_NORMAL);
        let u = el3(k + E_RECT_U);
        let v = el3(k + E_RECT_V);
        let half_u = elements[k + E_RECT_HALF_U];
        let half_v = elements[k + E_RECT_HALF_V];
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
    if (kind == EK_DISC) {
        let center = el3(k + E_DISC_CENTER);
        let normal = el3(k + E_DISC_NORMAL);
        let radius = elements[k + E_DISC_RADIUS];
        let r = x - center;
        let s = dot3(r, normal);
        let inplane = r - s * normal;
        let rho = sqrt(len2(inplane));
        if (rho <= radius) {
            return face(x - s * normal, normal, s);
        }
        return from_vector(center + inplane * (radius / rho), x, EDGE);
    }
    if (kind == EK_CYLINDER) {
        let base = el3(k + E_CYLINDER_BASE);
        let axis = el3(k + E_CYLINDER_AXIS);
        let radius = elements[k + E_CYLINDER_RADIUS];
        let length = elements[k + E_CYLINDER_LENGTH];
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
    // EK_TRIANGLE
    return triangle(el3(k + E_TRIANGLE_A), el3(k + E_TRIANGLE_B), el3(k + E_TRIANGLE_C), x);
}

fn distance_to(e: u32, q: vec3<f64>) -> f64 {
    let c = closest(e, q, 1.0e300lf);
    if (!c.found) {
        return 0.0lf;
    }
    return abs(c.distance);
}
