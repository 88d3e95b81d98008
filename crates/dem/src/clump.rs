//! Multi-sphere (clump) particles: templates of possibly overlapping spheres, their mass
//! properties, builders for the shapes calibration papers use, and the rigid-body rotation update.
//!
//! Mass properties are those of the union of the spheres (overlaps counted once), per unit
//! density. When the centres are collinear (rods, dumbbells) the union is a solid of revolution
//! whose cross-section is a disc of radius max_i sqrt(r_i^2 - (z - z_i)^2): piecewise polynomial
//! in z, so Gauss-Legendre between the breakpoints integrates it exactly. Otherwise a seeded,
//! stratified Monte Carlo (one jittered sample in each of 128^3 cells, 2.1 million samples) is
//! used; docs/physics.md asks for at least 1e6.

use glam::{DMat3, DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Most spheres one clump may have: a rod or a kernel of more would be a mesh of spheres, and
/// mass properties and contacts scale with the count.
pub const MAX_CLUMP_SPHERES: usize = 10_000;

/// Spheres in the template's own frame (any origin).
#[derive(Clone, Debug, PartialEq)]
pub struct ClumpTemplate {
    pub spheres: Vec<(DVec3, f64)>,
}

/// Mass properties per unit density.
#[derive(Clone, Copy, Debug)]
pub struct MassProperties {
    pub volume: f64,
    /// Centre of mass in the template frame.
    pub centroid: DVec3,
    /// Principal moments of inertia (per unit density), ascending.
    pub principal_inertia: DVec3,
    /// Columns are the principal axes in the template frame (a rotation).
    pub axes: DMat3,
    /// Whether the values are exact (collinear centres) or sampled.
    pub exact: bool,
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points: exact for polynomials up to degree 15.
const GL_NODES: [f64; 8] = [
    -0.960_289_856_497_536_2,
    -0.796_666_477_413_626_7,
    -0.525_532_409_916_329,
    -0.183_434_642_495_649_8,
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_2,
];
const GL_WEIGHTS: [f64; 8] = [
    0.101_228_536_290_376_26,
    0.222_381_034_453_374_47,
    0.313_706_645_877_887_3,
    0.362_683_783_378_362,
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_47,
    0.101_228_536_290_376_26,
];

impl ClumpTemplate {
    pub fn new(spheres: Vec<(DVec3, f64)>) -> Result<ClumpTemplate, String> {
        if spheres.is_empty() {
            return Err("clump: expected at least one sphere".into());
        }
        if spheres.len() > MAX_CLUMP_SPHERES {
            return Err(format!(
                "clump: {} spheres, at most {MAX_CLUMP_SPHERES} in one clump",
                spheres.len()
            ));
        }
        if let Some((_, r)) = spheres.iter().find(|(_, r)| r.is_nan() || *r <= 0.0) {
            return Err(format!("clump: sphere radius must be positive, got {r}"));
        }
        Ok(ClumpTemplate { spheres })
    }

    /// A straight rod of `count` equal spheres spanning `length` end to end (the outer spheres
    /// touch the ends), diameter `diameter`, along x: stalk and silage pieces.
    pub fn rod(length: f64, diameter: f64, count: usize) -> Result<ClumpTemplate, String> {
        let r = 0.5 * diameter;
        // Checked before the spheres are made: 1e9 would ask 32 GB here.
        if count > MAX_CLUMP_SPHERES {
            return Err(format!(
                "rod: count = {count} spheres, at most {MAX_CLUMP_SPHERES} in one clump"
            ));
        }
        if count == 0 || length < diameter || diameter <= 0.0 {
            return Err(format!(
                "rod: expected count >= 1 and length >= diameter > 0, got count {count}, length {length}, diameter {diameter}"
            ));
        }
        if count == 1 && length > diameter {
            return Err("rod: one sphere cannot span a length longer than its diameter".into());
        }
        let span = length - diameter;
        let spheres = (0..count)
            .map(|i| {
                let x = if count == 1 {
                    0.0
                } else {
                    -0.5 * span + span * i as f64 / (count - 1) as f64
                };
                (DVec3::new(x, 0.0, 0.0), r)
            })
            .collect();
        ClumpTemplate::new(spheres)
    }

    fn collinear_axis(&self) -> Option<(DVec3, DVec3)> {
        let c0 = self.spheres[0].0;
        let far = self
            .spheres
            .iter()
            .map(|(c, _)| *c)
            .max_by(|a, b| (*a - c0).length().total_cmp(&(*b - c0).length()))?;
        let scale = self.spheres.iter().map(|(_, r)| *r).fold(0.0, f64::max);
        if (far - c0).length() < 1e-12 * scale {
            return Some((c0, DVec3::X));
        }
        let axis = (far - c0).normalize();
        self.spheres
            .iter()
            .all(|(c, _)| (*c - c0).cross(axis).length() < 1e-9 * scale)
            .then_some((c0, axis))
    }

    /// Volume, centroid and principal inertia of the union, per unit density.
    pub fn mass_properties(&self) -> MassProperties {
        match self.collinear_axis() {
            Some((origin, axis)) => self.axial_properties(origin, axis),
            None => self.sampled_properties(128, 0x5eed),
        }
    }

    /// Exact properties of collinear spheres by slicing along the axis.
    fn axial_properties(&self, origin: DVec3, axis: DVec3) -> MassProperties {
        let zs: Vec<(f64, f64)> = self
            .spheres
            .iter()
            .map(|(c, r)| ((*c - origin).dot(axis), *r))
            .collect();
        // Breakpoints: sphere ends and the planes where two spheres' sections are equal.
        let mut cuts: Vec<f64> = zs.iter().flat_map(|&(z, r)| [z - r, z + r]).collect();
        for (a, &(za, ra)) in zs.iter().enumerate() {
            for &(zb, rb) in &zs[a + 1..] {
                if (za - zb).abs() > 0.0 {
                    // ra^2 - (z - za)^2 = rb^2 - (z - zb)^2 is linear in z.
                    cuts.push((ra * ra - rb * rb + zb * zb - za * za) / (2.0 * (zb - za)));
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-15);
        let section2 = |z: f64| {
            zs.iter()
                .map(|&(zi, ri)| ri * ri - (z - zi).powi(2))
                .fold(0.0, f64::max)
        };
        // Moments of the slices: area pi s^2, first moment, and inertia terms.
        let (mut v, mut mz, mut mzz, mut mss) = (0.0, 0.0, 0.0, 0.0);
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b <= a {
                continue;
            }
            let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
            for (x, wt) in GL_NODES.iter().zip(&GL_WEIGHTS) {
                let z = mid + half * x;
                let s2 = section2(z);
                let dv = std::f64::consts::PI * s2 * wt * half;
                v += dv;
                mz += dv * z;
                mzz += dv * z * z;
                // A disc of radius s: integral of (x^2 + y^2) dA = pi s^4 / 2.
                mss += 0.5 * dv * s2;
            }
        }
        let zc = mz / v;
        let axial = mss;
        // Perpendicular: integral of (y^2 + (z - zc)^2) = mss / 2 + (mzz - zc mz).
        let transverse = 0.5 * mss + (mzz - zc * mz);
        let centroid = origin + zc * axis;
        let (p, q) = perpendicular_pair(axis);
        let mut inertia = [(axial, axis), (transverse, p), (transverse, q)];
        inertia.sort_by(|a, b| a.0.total_cmp(&b.0));
        MassProperties {
            volume: v,
            centroid,
            principal_inertia: DVec3::new(inertia[0].0, inertia[1].0, inertia[2].0),
            axes: right_handed(inertia[0].1, inertia[1].1, inertia[2].1),
            exact: true,
        }
    }

    /// Stratified Monte Carlo over the bounding box: one jittered sample per cell of an n^3 grid.
    pub fn sampled_properties(&self, n: usize, seed: u64) -> MassProperties {
        let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for (c, r) in &self.spheres {
            lo = lo.min(*c - DVec3::splat(*r));
            hi = hi.max(*c + DVec3::splat(*r));
        }
        let cell = (hi - lo) / n as f64;
        let dv = cell.x * cell.y * cell.z;
        let mut rng = Pcg64::seed_from_u64(seed);
        let (mut count, mut s1, mut s2) = (0u64, DVec3::ZERO, [[0.0f64; 3]; 3]);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let jit = DVec3::new(rng.gen(), rng.gen(), rng.gen());
                    let x = lo + (DVec3::new(i as f64, j as f64, k as f64) + jit) * cell;
                    if self
                        .spheres
                        .iter()
                        .any(|(c, r)| (x - *c).length_squared() <= r * r)
                    {
                        count += 1;
                        s1 += x;
                        let a = x.to_array();
                        for (p, row) in s2.iter_mut().enumerate() {
                            for (q, v) in row.iter_mut().enumerate() {
                                *v += a[p] * a[q];
                            }
                        }
                    }
                }
            }
        }
        let volume = count as f64 * dv;
        let centroid = s1 / count as f64;
        // Second moments about the centroid, then the inertia tensor.
        let c = centroid.to_array();
        let mut cov = [[0.0f64; 3]; 3];
        for p in 0..3 {
            for q in 0..3 {
                cov[p][q] = (s2[p][q] / count as f64 - c[p] * c[q]) * volume;
            }
        }
        from_second_moments(volume, centroid, cov, false)
    }
}

/// Mass properties (per unit density) from the volume, the centroid and the second moments
/// `cov[p][q]` = integral of (x_p - c_p)(x_q - c_q) dV about the centroid.
pub(crate) fn from_second_moments(
    volume: f64,
    centroid: DVec3,
    cov: [[f64; 3]; 3],
    exact: bool,
) -> MassProperties {
    let trace = cov[0][0] + cov[1][1] + cov[2][2];
    let inertia = nalgebra::Matrix3::from_fn(|p, q| (if p == q { trace } else { 0.0 }) - cov[p][q]);
    let eig = nalgebra::SymmetricEigen::new(inertia);
    let mut pairs: Vec<(f64, DVec3)> = (0..3)
        .map(|i| {
            let v = eig.eigenvectors.column(i);
            (eig.eigenvalues[i], DVec3::new(v[0], v[1], v[2]).normalize())
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    MassProperties {
        volume,
        centroid,
        principal_inertia: DVec3::new(pairs[0].0, pairs[1].0, pairs[2].0),
        axes: right_handed(pairs[0].1, pairs[1].1, pairs[2].1),
        exact,
    }
}

fn perpendicular_pair(axis: DVec3) -> (DVec3, DVec3) {
    let helper = if axis.x.abs() < 0.9 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let p = axis.cross(helper).normalize();
    (p, axis.cross(p))
}

fn right_handed(a: DVec3, b: DVec3, c: DVec3) -> DMat3 {
    let c = if a.cross(b).dot(c) < 0.0 { -c } else { c };
    DMat3::from_cols(a, b, c)
}

/// Rotational state of a rigid body: orientation (body to space) and angular momentum in the
/// space frame, with principal moments of inertia.
#[derive(Clone, Copy, Debug)]
pub struct RigidRotation {
    pub orientation: DQuat,
    pub angular_momentum: DVec3,
    pub principal_inertia: DVec3,
}

impl RigidRotation {
    /// Angular velocity in the space frame: R I^-1 R^T L.
    pub fn angular_velocity(&self) -> DVec3 {
        omega(
            self.orientation,
            self.angular_momentum,
            self.principal_inertia,
        )
    }

    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.angular_momentum.dot(self.angular_velocity())
    }

    /// Advances the orientation over `dt` at fixed angular momentum with the second-order
    /// Richardson iteration of LAMMPS' fix rigid: a full step and two half steps (the second at the
    /// half-step angular velocity), combined as 2 q_half - q_full.
    pub fn advance_orientation(&mut self, dt: f64) {
        let (q, l, i) = (
            self.orientation,
            self.angular_momentum,
            self.principal_inertia,
        );
        let rate = |q: DQuat| {
            let w = omega(q, l, i);
            DQuat::from_xyzw(w.x, w.y, w.z, 0.0) * q * 0.5
        };
        let dq = rate(q);
        let full = (q + dq * dt).normalize();
        let mut half = (q + dq * (0.5 * dt)).normalize();
        half = (half + rate(half) * (0.5 * dt)).normalize();
        self.orientation = (half * 2.0 - full).normalize();
    }
}

/// Clumps in a simulation: rigid bodies whose member spheres are ordinary particles (flagged by
/// `Particles::body`), so contact detection and forces need no special case beyond skipping pairs
/// of one body. Each member carries its body's mass, which is what its contacts should see.
#[derive(Clone, Debug, Default)]
pub struct Bodies {
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub rotation: Vec<RigidRotation>,
    pub mass: Vec<f64>,
    /// Member particles by stable id.
    pub members: Vec<Vec<u32>>,
    /// Force and torque (about the centre of mass) from the last force evaluation, and the summed
    /// constant-directional rolling resistance of the members.
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    pub rolling_limit: Vec<f64>,
    /// Which bodies are convex polyhedra (with one member, the proxy sphere that bounds the
    /// polyhedron), their shapes and world frames.
    pub polyhedra: crate::polyhedron::PolyFrames,
}

impl Bodies {
    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Adds a clump of `template` (with its `props`) of material density `density`, centre of mass
    /// at `position`, body axes rotated by `orientation` from the template's principal axes.
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        particles: &mut crate::particles::Particles,
        template: &ClumpTemplate,
        props: &MassProperties,
        density: f64,
        material: usize,
        position: DVec3,
        orientation: DQuat,
        velocity: DVec3,
    ) -> usize {
        let b = self.len();
        let mass = density * props.volume;
        // Body frame = principal axes, origin at the centroid.
        let to_body = props.axes.transpose();
        let mut members = Vec::new();
        for (c, r) in &template.spheres {
            let offset = to_body * (*c - props.centroid);
            let id = particles.len() as u32;
            particles.push(
                position + orientation * offset,
                velocity,
                *r,
                density,
                material,
            );
            let k = particles.len() - 1;
            particles.mass[k] = mass;
            particles.inv_mass[k] = 1.0 / mass;
            particles.body[k] = b as u32;
            particles.body_offset[k] = offset;
            members.push(id);
        }
        self.position.push(position);
        self.velocity.push(velocity);
        self.rotation.push(RigidRotation {
            orientation,
            angular_momentum: DVec3::ZERO,
            principal_inertia: props.principal_inertia * density,
        });
        self.mass.push(mass);
        self.members.push(members);
        self.force.push(DVec3::ZERO);
        self.torque.push(DVec3::ZERO);
        self.rolling_limit.push(0.0);
        self.polyhedra.push(None);
        b
    }

    /// Adds a convex polyhedron drawn at `scale`, of material density `density`, centre of mass
    /// at `position`, body axes rotated by `orientation`: a body with one member sphere centred on
    /// the centre of mass and holding the polyhedron, which the neighbour search sees (see
    /// [`crate::polyhedron`]).
    #[allow(clippy::too_many_arguments)]
    pub fn add_polyhedron(
        &mut self,
        particles: &mut crate::particles::Particles,
        shape: &std::sync::Arc<crate::polyhedron::ConvexPolyhedron>,
        scale: f64,
        density: f64,
        material: usize,
        position: DVec3,
        orientation: DQuat,
        velocity: DVec3,
    ) -> usize {
        let proxy = ClumpTemplate {
            spheres: vec![(DVec3::ZERO, shape.bounding_radius * scale)],
        };
        let unit = shape.mass_properties();
        let props = MassProperties {
            volume: unit.volume * scale.powi(3),
            principal_inertia: unit.principal_inertia * scale.powi(5),
            ..unit
        };
        let b = self.add(
            particles,
            &proxy,
            &props,
            density,
            material,
            position,
            orientation,
            velocity,
        );
        self.polyhedra.set_last(shape, scale);
        b
    }

    /// Refreshes the polyhedra's world vertices and planes from the bodies' poses.
    pub fn update_polyhedra(&mut self) {
        if self.polyhedra.any() {
            let rotation = &self.rotation;
            self.polyhedra
                .update(&self.position, |b| rotation[b].orientation);
        }
    }

    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .map(|b| {
                0.5 * self.mass[b] * self.velocity[b].length_squared()
                    + self.rotation[b].kinetic_energy()
            })
            .sum()
    }

    /// Half kick of body `b` with its stored force and torque; the rolling resistance brakes the
    /// angular momentum along the spin, at most to rest.
    pub fn kick(&mut self, b: usize, half_dt: f64) {
        let load = (self.force[b], self.torque[b], self.rolling_limit[b]);
        kick_body(
            &mut self.velocity[b],
            &mut self.rotation[b],
            self.mass[b],
            load,
            half_dt,
        );
    }

    /// Every body's half kick ([`Self::kick`]), and with `drift_dt` its drift and turn over that
    /// time, in parallel.
    pub fn kick_all(&mut self, half_dt: f64, drift_dt: Option<f64>) {
        use rayon::prelude::*;
        let (mass, force, torque, limit) =
            (&self.mass, &self.force, &self.torque, &self.rolling_limit);
        self.velocity
            .par_iter_mut()
            .zip(self.rotation.par_iter_mut())
            .zip(self.position.par_iter_mut())
            .enumerate()
            .with_min_len(256)
            .for_each(|(b, ((v, rot), x))| {
                kick_body(v, rot, mass[b], (force[b], torque[b], limit[b]), half_dt);
                if let Some(dt) = drift_dt {
                    *x += *v * dt;
                    rot.advance_orientation(dt);
                }
            });
    }
}

/// Half kick of one body of mass `mass` under `(force, torque, rolling limit)`.
fn kick_body(
    velocity: &mut DVec3,
    rot: &mut RigidRotation,
    mass: f64,
    (force, torque, rolling_limit): (DVec3, DVec3, f64),
    half_dt: f64,
) {
    *velocity += force * (half_dt / mass);
    {
        rot.angular_momentum += torque * half_dt;
        let brake = rolling_limit * half_dt;
        if brake > 0.0 {
            let w = rot.angular_velocity();
            let s = w.length();
            if s > 0.0 {
                let dir = w / s;
                let along = rot.angular_momentum.dot(dir);
                let cut = brake.min(along.max(0.0));
                rot.angular_momentum -= dir * cut;
            }
        }
    }
}

fn omega(q: DQuat, l: DVec3, inertia: DVec3) -> DVec3 {
    let body = q.inverse() * l;
    q * (body / inertia)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn rod_spacing_and_single_sphere() {
        let rod = ClumpTemplate::rod(0.03, 0.006, 6).unwrap();
        assert_eq!(rod.spheres.len(), 6);
        assert!((rod.spheres[0].0.x + 0.012).abs() < 1e-15);
        assert!((rod.spheres[5].0.x - 0.012).abs() < 1e-15);
        let one = ClumpTemplate::new(vec![(DVec3::ZERO, 0.01)]).unwrap();
        let m = one.mass_properties();
        assert!((m.volume - 4.0 / 3.0 * PI * 1e-6).abs() < 1e-18);
        assert!((m.principal_inertia.x - 0.4 * m.volume * 1e-4).abs() < 1e-20);
        assert!(ClumpTemplate::rod(0.01, 0.02, 2).is_err());
        // Refused before anything is allocated (this asked 32 GB).
        assert_eq!(
            ClumpTemplate::rod(0.03, 0.006, 1_000_000_000).unwrap_err(),
            "rod: count = 1000000000 spheres, at most 10000 in one clump"
        );
    }
}
