//! Particle factories: a disc or rectangle that creates a mixture at a rate during the run, as
//! EDEM's dynamic factories do (pouring material into a cylinder, a hopper, a seeder).
//!
//! Particles are created in a slab behind the face, as deep as the largest particle, with their
//! centre far enough inside the footprint that the whole particle is. Each batch tries to place
//! what is due by now; a particle that finds no free spot (the slab is still crowded by the last
//! batch) waits for the next batch, so the real rate falls below the asked one only when the
//! face is too small for it.

use crate::mixture::{random_orientation, Drawn, FillTarget, Item, Mixture};
use crate::sim::walls::visit_elements;
use crate::sim::{OnDevice, SimError, Simulation, StepExtension};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// The face particles come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FactoryShape {
    Disc {
        centre: DVec3,
        radius: f64,
    },
    /// Half sizes along the two in-face axes `u` and `v`.
    Rectangle {
        centre: DVec3,
        u: DVec3,
        v: DVec3,
        half_u: f64,
        half_v: f64,
    },
}

impl FactoryShape {
    /// Box around the slab `depth` deep behind the face along `normal`.
    pub fn slab_bounds(&self, normal: DVec3, depth: f64) -> (DVec3, DVec3) {
        let (centre, ext) = match *self {
            FactoryShape::Disc { centre, radius } => {
                (centre, crate::geometry::disc_extent(normal, radius))
            }
            FactoryShape::Rectangle {
                centre,
                u,
                v,
                half_u,
                half_v,
            } => (centre, (u * half_u).abs() + (v * half_v).abs()),
        };
        let far = centre + normal * depth;
        (centre.min(far) - ext, centre.max(far) + ext)
    }
}

/// How fast to create: particles per second, or kg per second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rate {
    Count(f64),
    Mass(f64),
}

#[derive(Clone, Debug)]
pub struct Factory {
    pub name: String,
    pub shape: FactoryShape,
    /// Unit vector into the slab (particles are created on this side of the face).
    pub normal: DVec3,
    pub mixture: Mixture,
    pub total: FillTarget,
    pub rate: Rate,
    pub start: f64,
    pub velocity: DVec3,
    /// Seconds between batches.
    pub interval: f64,
    rng: Pcg64,
    drawn: Drawn,
    /// The next particle, drawn but not yet placed.
    pending: Option<Item>,
    next_batch: f64,
    /// Particles created so far.
    pub created: usize,
    pub created_mass: f64,
}

impl Factory {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        shape: FactoryShape,
        normal: DVec3,
        mixture: Mixture,
        total: FillTarget,
        rate: Rate,
        start: f64,
        velocity: DVec3,
        seed: u64,
    ) -> Factory {
        // A batch about every time a particle needs to clear the slab, but at least every 5 ms.
        let depth = 2.0 * mixture.bounding_radius();
        let speed = velocity.dot(normal).max(0.0);
        let interval = if speed > 0.0 {
            (0.5 * depth / speed).min(0.005)
        } else {
            0.005
        };
        Factory {
            name: name.into(),
            shape,
            normal: normal.normalize(),
            mixture,
            total,
            rate,
            start,
            velocity,
            interval,
            rng: Pcg64::seed_from_u64(seed),
            drawn: Drawn::default(),
            pending: None,
            next_batch: start,
            created: 0,
            created_mass: 0.0,
        }
    }

    /// Whether everything asked for has been created.
    pub fn done(&self) -> bool {
        match self.total {
            FillTarget::Count(n) => self.created >= n,
            FillTarget::Mass(m) => self.created_mass >= m,
        }
    }

    /// Box around the slab (for the domain and for finding particles near it).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.shape
            .slab_bounds(self.normal, 2.0 * self.mixture.bounding_radius())
    }

    /// Whether a batch is due at `time`.
    pub fn due(&self, time: f64) -> bool {
        !self.done() && time + 1e-12 >= self.next_batch
    }

    /// Places the particles due at `time`. `is_free(x, r)` says whether a sphere fits (no particle
    /// or wall there); placed particles are returned and must be added before the next call.
    pub fn batch(&mut self, time: f64, mut is_free: impl FnMut(DVec3, f64) -> bool) -> Vec<Item> {
        self.next_batch = time + self.interval;
        let elapsed = time - self.start;
        let mut placed: Vec<(DVec3, f64)> = Vec::new();
        let mut out = Vec::new();
        let mut members = Vec::new();
        let depth = 2.0 * self.mixture.bounding_radius();
        loop {
            if self.done() {
                break;
            }
            let behind = match self.rate {
                Rate::Count(r) => (self.created as f64) < r * elapsed,
                Rate::Mass(r) => self.created_mass < r * elapsed,
            };
            if !behind {
                break;
            }
            let mut item = match self.pending.take() {
                Some(it) => it,
                None => self.mixture.draw(&mut self.drawn, &mut self.rng),
            };
            let t = &self.mixture.types[item.kind];
            let b = t.bounding_radius() * item.size / t.size.max_radius();
            let mut ok = false;
            for _ in 0..50 {
                let (u1, u2): (f64, f64) = (self.rng.gen(), self.rng.gen());
                let on_face = match self.shape {
                    FactoryShape::Disc { centre, radius } => {
                        let (e1, e2) = perpendicular_axes(self.normal);
                        let rho = (radius - b).max(0.0) * u1.sqrt();
                        let phi = std::f64::consts::TAU * u2;
                        centre + (e1 * phi.cos() + e2 * phi.sin()) * rho
                    }
                    FactoryShape::Rectangle {
                        centre,
                        u,
                        v,
                        half_u,
                        half_v,
                    } => {
                        centre
                            + u * (half_u - b).max(0.0) * (2.0 * u1 - 1.0)
                            + v * (half_v - b).max(0.0) * (2.0 * u2 - 1.0)
                    }
                };
                let d = b + (depth - 2.0 * b).max(0.0) * self.rng.gen::<f64>();
                item.position = on_face + self.normal * d;
                item.orientation = random_orientation(&mut self.rng);
                t.spheres(&item, &mut members);
                let clear = members.iter().all(|(x, r)| {
                    is_free(*x, *r)
                        && placed
                            .iter()
                            .all(|(y, q)| (*x - *y).length_squared() >= (r + q) * (r + q))
                });
                if clear {
                    ok = true;
                    break;
                }
            }
            if !ok {
                self.pending = Some(item);
                break;
            }
            placed.extend(members.iter().cloned());
            self.created += 1;
            self.created_mass += t.mass(item.size);
            out.push(item);
        }
        out
    }
}

/// Two unit vectors perpendicular to `n` and to each other.
pub fn perpendicular_axes(n: DVec3) -> (DVec3, DVec3) {
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let e1 = n.cross(helper).normalize();
    (e1, n.cross(e1))
}

/// A factory is a per-step extension: when a batch is due it places what its rate owes by now.
impl StepExtension for Factory {
    fn name(&self) -> &str {
        &self.name
    }

    /// A batch needs the host; the steps until the next one (`idle_steps`) stay on the device.
    fn on_device(&self) -> OnDevice {
        OnDevice::BetweenSegments
    }

    fn after_step(&mut self, sim: &mut Simulation) -> Result<(), SimError> {
        let time = sim.time;
        if !self.due(time) {
            return Ok(());
        }
        let (lo, hi) = self.bounds();
        let pad = DVec3::splat(2.0 * sim.prepared_radius());
        let (lo, hi) = (lo - pad, hi + pad);
        let p = &sim.particles;
        let near: Vec<(DVec3, f64)> = (0..p.len())
            .filter(|&k| p.position[k].cmpge(lo).all() && p.position[k].cmple(hi).all())
            .map(|k| (p.position[k], p.radius[k]))
            .collect();
        let items = self.batch(time, |x, r| spot_is_free(sim, &near, x, r));
        sim.add_items(&self.mixture, &items, self.velocity);
        Ok(())
    }

    fn finished(&self) -> bool {
        self.done()
    }

    fn idle_steps(&self, time: f64, dt: f64) -> u64 {
        if self.done() {
            return u64::MAX;
        }
        // Steps until the next batch is due, less one for the round-off in the step times.
        let steps = ((self.next_batch - 1e-12 - time) / dt).floor();
        if steps.is_finite() && steps > 1.0 {
            steps as u64 - 1
        } else {
            0
        }
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// Whether a sphere at `x` of radius `r` touches a particle among `near` or any geometry.
fn spot_is_free(sim: &Simulation, near: &[(DVec3, f64)], x: DVec3, r: f64) -> bool {
    if near
        .iter()
        .any(|(y, q)| (x - *y).length_squared() < (r + q) * (r + q))
    {
        return false;
    }
    let mut clear = true;
    for geo in &sim.geometries {
        visit_elements(geo, x, |e| {
            if clear {
                if let Some(c) = geo.elements[e].closest(x, r) {
                    clear = c.distance >= r;
                }
            }
        });
    }
    clear
}

impl Simulation {
    /// Adds a particle factory (as a per-step extension).
    pub fn add_factory(&mut self, factory: Factory) {
        self.prepare_radius(factory.mixture.max_sphere_radius());
        self.add_extension(Box::new(factory));
    }

    /// The simulation's factories, in the order they were added.
    pub fn factories(&self) -> impl Iterator<Item = &Factory> {
        self.extensions_of::<Factory>()
    }

    /// Whether every factory has created all it should.
    pub fn factories_done(&self) -> bool {
        self.factories().all(|f| f.done())
    }
}
