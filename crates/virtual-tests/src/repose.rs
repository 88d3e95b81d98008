//! Angle-of-repose measurement on a particle heap, done the way labs do it on a photo
//! (docs/lab-tests.md, section 1): in several vertical planes through the heap axis, take the
//! surface profile (the highest particle surface per radial bin), fit a straight line to each flank
//! between the toe and the rounded apex, and report the mean angle and its spread over flanks and
//! planes.
//!
//! Guards, so that a heap too small to have flanks is refused rather than measured (a 100-bead
//! heap 2.6 beads high once gave 4.80 +- 7.43 deg with a flank at -5.9 deg and a NaN radius,
//! which a study would have fed to its model): every particle finite; the heap higher than two
//! particle diameters; at least three profile points per flank in the fit band; and every flank
//! falling away from the axis (a fitted angle above zero, finite). A flank level or rising
//! outward is a plane where the surface is a layer of beads with bumps, not a slope: it is
//! neither averaged in (it drags the mean down) nor dropped (that drags it up, and hides that
//! the heap is too small); the measurement fails naming it. Each failure is one line starting
//! "repose measurement:", and the lifted-cylinder test reports it as a failed measurement.

use glam::DVec3;

/// How to measure.
#[derive(Clone, Debug)]
pub struct ReposeMeasurement {
    /// Heap axis (vertical line through this x, y).
    pub axis: (f64, f64),
    /// Height of the base plate surface.
    pub base_z: f64,
    /// Number of vertical planes through the axis, evenly spaced in angle (each gives two flanks).
    pub planes: usize,
    /// Radial bin width of the profile (default: the mean particle diameter).
    pub bin_width: Option<f64>,
    /// Flank points used in the fit: heights between these fractions of the heap height, which
    /// leaves out the toe (the thin spread edge) and the rounded apex.
    pub fit_band: (f64, f64),
}

impl Default for ReposeMeasurement {
    fn default() -> Self {
        ReposeMeasurement {
            axis: (0.0, 0.0),
            base_z: 0.0,
            planes: 4,
            bin_width: None,
            fit_band: (0.15, 0.85),
        }
    }
}

/// One flank's profile points and fitted line z = intercept + slope * s (s the distance from the
/// axis along the flank).
#[derive(Clone, Debug)]
pub struct Flank {
    /// Plane angle (rad) and side (+1 or -1).
    pub plane_angle: f64,
    pub side: f64,
    /// (distance from the axis, surface height above the base) per bin.
    pub profile: Vec<(f64, f64)>,
    /// Points used in the fit.
    pub fitted: Vec<(f64, f64)>,
    pub slope: f64,
    pub intercept: f64,
    pub angle_deg: f64,
}

/// The result of a measurement.
#[derive(Clone, Debug)]
pub struct ReposeResult {
    pub angle_deg: f64,
    /// Sample standard deviation over the flanks.
    pub angle_std_deg: f64,
    /// Highest particle surface above the base.
    pub heap_height: f64,
    /// Mean distance from the axis at which the fitted flank lines meet the base.
    pub heap_radius: f64,
    pub flanks: Vec<Flank>,
}

/// A particle of the heap as the measurement sees it.
#[derive(Clone, Debug)]
pub enum HeapParticle {
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    /// A convex polyhedron: its world vertices and edges, and the radius of its equal-volume
    /// sphere (for the default bin width).
    Convex {
        centre: DVec3,
        vertices: Vec<DVec3>,
        edges: Vec<[u16; 2]>,
        equal_volume_radius: f64,
    },
}

impl HeapParticle {
    fn is_finite(&self) -> bool {
        match self {
            HeapParticle::Sphere { centre, radius } => centre.is_finite() && radius.is_finite(),
            HeapParticle::Convex {
                centre,
                vertices,
                equal_volume_radius,
                ..
            } => {
                centre.is_finite()
                    && equal_volume_radius.is_finite()
                    && vertices.iter().all(|v| v.is_finite())
            }
        }
    }

    fn size(&self) -> f64 {
        match self {
            HeapParticle::Sphere { radius, .. } => *radius,
            HeapParticle::Convex {
                equal_volume_radius,
                ..
            } => *equal_volume_radius,
        }
    }

    fn top(&self) -> f64 {
        match self {
            HeapParticle::Sphere { centre, radius } => centre.z + radius,
            HeapParticle::Convex { vertices, .. } => {
                vertices.iter().map(|v| v.z).fold(f64::MIN, f64::max)
            }
        }
    }

    /// Where the vertical plane through (ax, ay) with direction (dx, dy) cuts the particle: the
    /// particle centre's distance along the plane and the highest point of the cut.
    fn section_top(&self, ax: f64, ay: f64, dx: f64, dy: f64) -> Option<(f64, f64)> {
        let across = |p: DVec3| -(p.x - ax) * dy + (p.y - ay) * dx;
        let along = |p: DVec3| (p.x - ax) * dx + (p.y - ay) * dy;
        match self {
            HeapParticle::Sphere { centre, radius } => {
                let a = across(*centre);
                (a.abs() < *radius)
                    .then(|| (along(*centre), centre.z + (radius * radius - a * a).sqrt()))
            }
            HeapParticle::Convex {
                centre,
                vertices,
                edges,
                ..
            } => {
                let mut top = f64::MIN;
                for [u, v] in edges {
                    let (p, q) = (vertices[*u as usize], vertices[*v as usize]);
                    let (a, b) = (across(p), across(q));
                    if (a <= 0.0) != (b <= 0.0) {
                        top = top.max(p.z + (q.z - p.z) * (a / (a - b)));
                    } else {
                        // Corners lying in the plane.
                        if a == 0.0 {
                            top = top.max(p.z);
                        }
                        if b == 0.0 {
                            top = top.max(q.z);
                        }
                    }
                }
                (top > f64::MIN).then(|| (along(*centre), top))
            }
        }
    }
}

/// Measures the heap formed by spheres at `positions` with `radii`.
pub fn measure(
    positions: &[DVec3],
    radii: &[f64],
    m: &ReposeMeasurement,
) -> Result<ReposeResult, String> {
    let particles: Vec<HeapParticle> = positions
        .iter()
        .zip(radii)
        .map(|(c, r)| HeapParticle::Sphere {
            centre: *c,
            radius: *r,
        })
        .collect();
    measure_particles(&particles, m)
}

/// Measures the heap formed by `particles` (spheres and polyhedra).
pub fn measure_particles(
    particles: &[HeapParticle],
    m: &ReposeMeasurement,
) -> Result<ReposeResult, String> {
    if particles.is_empty() {
        return Err("repose measurement: no particles".into());
    }
    if m.planes == 0 {
        return Err("repose measurement: planes must be at least 1".into());
    }
    // A NaN or infinite particle would pass through every comparison below and come out as a
    // NaN angle.
    if let Some(k) = particles.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "repose measurement: particle {}: its position or size is not a finite number",
            k + 1
        ));
    }
    let mean_d = 2.0 * particles.iter().map(|p| p.size()).sum::<f64>() / particles.len() as f64;
    let bin = m.bin_width.unwrap_or(mean_d);
    let heap_height = particles
        .iter()
        .map(|p| p.top() - m.base_z)
        .fold(f64::MIN, f64::max);
    if heap_height <= 2.0 * mean_d {
        return Err(format!(
            "repose measurement: the heap is only {heap_height:.4} m high (about {:.1} particle diameters); there is no slope to measure",
            heap_height / mean_d
        ));
    }
    let mut flanks = Vec::new();
    for k in 0..m.planes {
        let phi = std::f64::consts::PI * k as f64 / m.planes as f64;
        let (dir_x, dir_y) = (phi.cos(), phi.sin());
        // Highest sphere surface in the plane, per signed radial bin.
        let mut bins: std::collections::BTreeMap<i64, f64> = std::collections::BTreeMap::new();
        for p in particles {
            // Where the plane cuts the particle, its top is this high.
            let Some((along, top)) = p.section_top(m.axis.0, m.axis.1, dir_x, dir_y) else {
                continue;
            };
            let top = top - m.base_z;
            let b = (along / bin).floor() as i64;
            let e = bins.entry(b).or_insert(f64::MIN);
            if top > *e {
                *e = top;
            }
        }
        for side in [1.0, -1.0] {
            let mut profile: Vec<(f64, f64)> = bins
                .iter()
                .map(|(&b, &z)| ((b as f64 + 0.5) * bin * side, z))
                .filter(|(s, _)| *s > 0.0)
                .collect();
            profile.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (lo, hi) = (m.fit_band.0 * heap_height, m.fit_band.1 * heap_height);
            let fitted: Vec<(f64, f64)> = profile
                .iter()
                .copied()
                .filter(|(_, z)| *z >= lo && *z <= hi)
                .collect();
            if fitted.len() < 3 {
                return Err(format!(
                    "repose measurement: plane {:.0} deg, side {side}: only {} profile points between {:.0} % and {:.0} % of the heap height",
                    phi.to_degrees(),
                    fitted.len(),
                    100.0 * m.fit_band.0,
                    100.0 * m.fit_band.1
                ));
            }
            let (slope, intercept) = line_fit(&fitted);
            flanks.push(Flank {
                plane_angle: phi,
                side,
                profile,
                fitted,
                slope,
                intercept,
                angle_deg: (-slope).atan().to_degrees(),
            });
        }
    }
    check_flanks(&flanks, heap_height / mean_d, m.fit_band)?;
    let n = flanks.len() as f64;
    let angle_deg = flanks.iter().map(|f| f.angle_deg).sum::<f64>() / n;
    let angle_std_deg = if flanks.len() > 1 {
        (flanks
            .iter()
            .map(|f| (f.angle_deg - angle_deg).powi(2))
            .sum::<f64>()
            / (n - 1.0))
            .sqrt()
    } else {
        0.0
    };
    let heap_radius = flanks
        .iter()
        .map(|f| {
            if f.slope < 0.0 {
                -f.intercept / f.slope
            } else {
                f64::NAN
            }
        })
        .sum::<f64>()
        / n;
    // Cannot happen with finite particles and descending flanks; kept so that no NaN ever
    // reaches a study as a measured angle.
    if ![angle_deg, angle_std_deg, heap_height, heap_radius]
        .iter()
        .all(|v| v.is_finite())
    {
        return Err(format!(
            "repose measurement: the result is not finite (angle {angle_deg} deg, spread {angle_std_deg} deg, height {heap_height} m, radius {heap_radius} m)"
        ));
    }
    Ok(ReposeResult {
        angle_deg,
        angle_std_deg,
        heap_height,
        heap_radius,
        flanks,
    })
}

/// Fails unless every flank falls away from the axis: a fitted angle that is finite and above
/// zero. The message counts the flanks that do not, names up to three, and gives the heap's
/// height in particle diameters (`diameters`).
fn check_flanks(flanks: &[Flank], diameters: f64, band: (f64, f64)) -> Result<(), String> {
    let bad: Vec<&Flank> = flanks
        .iter()
        .filter(|f| !(f.angle_deg.is_finite() && f.angle_deg > 0.0))
        .collect();
    if bad.is_empty() {
        return Ok(());
    }
    let named: Vec<String> = bad
        .iter()
        .take(3)
        .map(|f| {
            format!(
                "plane {:.0} deg, side {}: {:.2} deg",
                f.plane_angle.to_degrees(),
                f.side,
                f.angle_deg
            )
        })
        .collect();
    Err(format!(
        "repose measurement: {} of {} flanks do not fall away from the axis between {:.0} % and {:.0} % of the heap height ({}{}); a heap {diameters:.1} particle diameters high is too low or too small to show its slope: use more particles",
        bad.len(),
        flanks.len(),
        100.0 * band.0,
        100.0 * band.1,
        named.join("; "),
        if bad.len() > 3 { "; ..." } else { "" }
    ))
}

/// Least-squares line z = a + b s through the points; returns (b, a).
fn line_fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    let (ms, mz) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - ms).powi(2)).sum();
    let sxz: f64 = pts.iter().map(|p| (p.0 - ms) * (p.1 - mz)).sum();
    let b = if sxx > 0.0 { sxz / sxx } else { 0.0 };
    (b, mz - b * ms)
}

/// Reads sphere centres and radii from a CSV file with columns `x, y, z, radius` (a header row
/// naming them, any order, other columns ignored), or from a LAMMPS/LIGGGHTS custom dump (the
/// last frame; `ITEM: ATOMS ... x y z radius ...`). Lets a heap from another engine, or EDEM's
/// export, be measured exactly as demcal measures its own.
pub fn read_spheres(path: &std::path::Path) -> Result<(Vec<glam::DVec3>, Vec<f64>), String> {
    let name = path.display().to_string();
    let text = dem::files::read_text(path, dem::files::MAX_TABLE_BYTES)
        .map_err(|e| format!("{name}: cannot read: {e}"))?;
    parse_spheres(&name, &text)
}

/// The spheres of a CSV table or a LAMMPS/LIGGGHTS dump's text (see `read_spheres`); `name`
/// heads the errors.
pub fn parse_spheres(name: &str, text: &str) -> Result<(Vec<glam::DVec3>, Vec<f64>), String> {
    let columns = |header: &[&str]| -> Result<[usize; 4], String> {
        let mut idx = [usize::MAX; 4];
        for (k, want) in ["x", "y", "z", "radius"].iter().enumerate() {
            idx[k] = header
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case(want))
                .ok_or_else(|| {
                    format!(
                        "{name}: no column \"{want}\" (columns: {}); expected x, y, z, radius",
                        header.join(", ")
                    )
                })?;
        }
        Ok(idx)
    };
    let parse_rows = |rows: &[&str], sep: char, idx: [usize; 4], first_line: usize| {
        let mut xs = Vec::new();
        let mut rs = Vec::new();
        for (k, row) in rows.iter().enumerate() {
            if row.trim().is_empty() {
                continue;
            }
            let cells: Vec<&str> = if sep == ' ' {
                row.split_whitespace().collect()
            } else {
                row.split(sep).collect()
            };
            let get = |c: usize| -> Result<f64, String> {
                cells
                    .get(c)
                    .and_then(|v| v.trim().parse::<f64>().ok())
                    .ok_or_else(|| {
                        format!(
                            "{name}: line {}: expected a number in column {}",
                            first_line + k,
                            c + 1
                        )
                    })
            };
            xs.push(glam::DVec3::new(get(idx[0])?, get(idx[1])?, get(idx[2])?));
            rs.push(get(idx[3])?);
        }
        Ok::<_, String>((xs, rs))
    };
    let lines: Vec<&str> = text.lines().collect();
    let out = if let Some(start) = lines.iter().rposition(|l| l.starts_with("ITEM: ATOMS")) {
        let header: Vec<&str> = lines[start]["ITEM: ATOMS".len()..]
            .split_whitespace()
            .collect();
        let end = lines[start + 1..]
            .iter()
            .position(|l| l.starts_with("ITEM:"))
            .map_or(lines.len(), |e| start + 1 + e);
        let rows = parse_rows(&lines[start + 1..end], ' ', columns(&header)?, start + 2)?;
        // The frame's header says how many atoms follow; a file cut short or pasted together
        // disagrees with it.
        if let Some(n) = lines[..start]
            .iter()
            .rposition(|l| l.starts_with("ITEM: NUMBER OF ATOMS"))
        {
            let declared = lines
                .get(n + 1)
                .and_then(|l| l.trim().parse::<usize>().ok())
                .ok_or_else(|| format!("{name}: line {}: expected the number of atoms", n + 2))?;
            if declared != rows.0.len() {
                return Err(format!(
                    "{name}: line {}: the frame declares {declared} atoms but holds {} rows",
                    n + 2,
                    rows.0.len()
                ));
            }
        }
        rows
    } else {
        let header: Vec<&str> = lines
            .first()
            .map(|l| l.split(',').collect())
            .unwrap_or_default();
        parse_rows(&lines[1.min(lines.len())..], ',', columns(&header)?, 2)?
    };
    if out.0.is_empty() {
        return Err(format!("{name}: no spheres in the file"));
    }
    // A heap from another engine may hold anything; the measurement needs real spheres.
    for (k, (p, r)) in out.0.iter().zip(&out.1).enumerate() {
        if !(r.is_finite() && *r > 0.0) {
            return Err(format!(
                "{name}: sphere {}: radius {r}: expected a positive number (m)",
                k + 1
            ));
        }
        if !p.is_finite() {
            return Err(format!(
                "{name}: sphere {}: position ({}, {}, {}): expected finite numbers (m)",
                k + 1,
                p.x,
                p.y,
                p.z
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cone heap of equal spheres: columns on a jittered square grid, stacked at 2r from the
    /// base, each topped by one sphere whose top lies on the cone surface z = H - tan(angle) rho
    /// (so the surface is not a lattice staircase).
    fn cone(angle_deg: f64, radius: f64, r: f64, seed: u64) -> (Vec<DVec3>, Vec<f64>) {
        let t = angle_deg.to_radians().tan();
        let height = radius * t;
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        let mut jitter = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.4 * r
        };
        let (mut pos, mut rad) = (Vec::new(), Vec::new());
        let n = (radius / (2.0 * r)).ceil() as i64;
        for ix in -n..=n {
            for iy in -n..=n {
                let (x, y) = (
                    2.0 * r * ix as f64 + jitter(),
                    2.0 * r * iy as f64 + jitter(),
                );
                let top = height - t * (x * x + y * y).sqrt();
                if top < 2.0 * r {
                    continue;
                }
                let mut z = r;
                while z + r < top - r {
                    pos.push(DVec3::new(x, y, z));
                    rad.push(r);
                    z += 2.0 * r;
                }
                pos.push(DVec3::new(x, y, top - r));
                rad.push(r);
            }
        }
        (pos, rad)
    }

    #[test]
    fn synthetic_cones_come_back_within_half_a_degree() {
        for angle in [25.0, 35.0, 45.0] {
            let (p, r) = cone(angle, 0.06, 0.001, 7);
            let res = measure(&p, &r, &ReposeMeasurement::default()).unwrap();
            eprintln!(
                "cone {angle} deg ({} spheres): measured {:.3} +- {:.3} deg, height {:.4} m, radius {:.4} m",
                p.len(),
                res.angle_deg,
                res.angle_std_deg,
                res.heap_height,
                res.heap_radius
            );
            assert!(
                (res.angle_deg - angle).abs() < 0.5,
                "{angle}: {}",
                res.angle_deg
            );
            assert_eq!(res.flanks.len(), 8);
        }
    }

    #[test]
    fn a_flat_layer_is_refused() {
        let p: Vec<DVec3> = (0..100)
            .map(|i| DVec3::new(0.002 * (i % 10) as f64, 0.002 * (i / 10) as f64, 0.001))
            .collect();
        let r = vec![0.001; 100];
        let e = measure(&p, &r, &ReposeMeasurement::default()).unwrap_err();
        assert!(e.contains("no slope to measure"), "{e}");
    }
}
