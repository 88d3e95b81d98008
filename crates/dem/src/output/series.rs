//! A run's snapshots: the files of each one and the `.pvd` collections that list them (see the
//! module documentation of [`super`]).

use super::pvd::Collection;
use super::vtp::{Encoding, PolyData};
use super::{contacts, geometry, particles, polyhedra, write_atomically};
use crate::sim::Simulation;
use glam::{DMat3, DVec3};
use std::io;
use std::path::{Path, PathBuf};

/// What the snapshots hold and how they are stored (a scene's `[output]` `format` and
/// `contacts`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SnapshotOptions {
    pub encoding: Encoding,
    /// Write the contact force network (`contacts_*.vtp`): it costs a pass over the pair list and
    /// about as much disk as the particles.
    pub contacts: bool,
}

/// The snapshots of one run into one folder.
pub struct Snapshots {
    dir: PathBuf,
    options: SnapshotOptions,
    particles: Collection,
    geometry: Collection,
    contacts: Collection,
    bonds: Collection,
    polyhedra: Collection,
    geometry_state: Option<GeometryState>,
    last_step: Option<u64>,
    written: usize,
}

/// What the geometry files written so far hold.
struct GeometryState {
    /// The box that cuts infinite planes.
    extent: (DVec3, DVec3),
    /// Each geometry's pose at the first snapshot.
    start: Vec<(DMat3, DVec3)>,
    /// Geometries written with every snapshot: those with a motion, or that have moved.
    moving: Vec<bool>,
    /// The static file: which geometries it holds and its name.
    still: Option<(Vec<usize>, String)>,
}

impl Snapshots {
    /// Snapshots into `dir` (which must exist); nothing is written until [`Self::write`].
    pub fn new(dir: &Path, options: SnapshotOptions) -> Self {
        Snapshots {
            dir: dir.to_path_buf(),
            options,
            particles: Collection::new(&dir.join("particles.pvd")),
            geometry: Collection::new(&dir.join("geometry.pvd")),
            contacts: Collection::new(&dir.join("contacts.pvd")),
            bonds: Collection::new(&dir.join("bonds.pvd")),
            polyhedra: Collection::new(&dir.join("polyhedra.pvd")),
            geometry_state: None,
            last_step: None,
            written: 0,
        }
    }

    /// Snapshots written (a step written twice counts once).
    pub fn count(&self) -> usize {
        self.written
    }

    /// Writes the snapshot of the simulation's current state and rewrites the collections. The
    /// simulation is mutable only so that the contacts can be gathered (see
    /// [`Simulation::pair_contacts`]); its state is not changed.
    pub fn write(&mut self, sim: &mut Simulation) -> io::Result<()> {
        let (step, time) = (sim.steps, sim.time);
        if self.last_step == Some(step) {
            // The same state again (a run's last snapshot): its files are rewritten, listed once.
            for c in self.collections_mut() {
                c.retain(|e| e.time != time);
            }
        } else {
            self.written += 1;
        }
        self.last_step = Some(step);
        let name = |kind: &str| format!("{kind}_{step:08}.vtp");

        let file = name("particles");
        self.write_file(
            &file,
            &particles::polydata(&sim.particles, &sim.bodies),
            time,
        )?;
        self.particles.add(time, 0, &file);

        if !sim.geometries.is_empty() {
            self.write_geometry(sim, &name("geometry"), &name("geometry_static"))?;
        }
        if self.options.contacts {
            let pairs = sim.pair_contacts();
            let file = name("contacts");
            self.write_file(&file, &contacts::polydata(&sim.particles, &pairs), time)?;
            self.contacts.add(time, 0, &file);
        }
        sim.bodies.update_polyhedra();
        if let Some(data) = polyhedra::polydata(&sim.particles, &sim.bodies) {
            let file = name("polyhedra");
            self.write_file(&file, &data, time)?;
            self.polyhedra.add(time, 0, &file);
        }
        if let Some(bonds) = sim.bonds() {
            let file = name("bonds");
            let data = crate::bond::output::bonds_polydata(bonds, &sim.particles);
            self.write_file(&file, &data, time)?;
            self.bonds.add(time, 0, &file);
        }
        // Last, so that every file a collection lists is already complete.
        for c in [
            &self.particles,
            &self.geometry,
            &self.contacts,
            &self.bonds,
            &self.polyhedra,
        ] {
            if !c.entries().is_empty() {
                c.write()?;
            }
        }
        Ok(())
    }

    fn collections_mut(&mut self) -> [&mut Collection; 5] {
        [
            &mut self.particles,
            &mut self.geometry,
            &mut self.contacts,
            &mut self.bonds,
            &mut self.polyhedra,
        ]
    }

    fn write_file(&self, file: &str, data: &PolyData, time: f64) -> io::Result<()> {
        write_atomically(&self.dir.join(file), |w| {
            data.write(w, self.options.encoding, time)
        })
    }

    fn write_geometry(
        &mut self,
        sim: &Simulation,
        moving_file: &str,
        still_file: &str,
    ) -> io::Result<()> {
        let geometries = &sim.geometries;
        let time = sim.time;
        let pose = |k: usize| (geometries[k].rotation, geometries[k].translation);
        let fresh = self
            .geometry_state
            .as_ref()
            .is_none_or(|s| s.start.len() != geometries.len());
        if fresh {
            self.geometry_state = Some(GeometryState {
                extent: plane_extent(sim),
                start: (0..geometries.len()).map(pose).collect(),
                moving: vec![false; geometries.len()],
                still: None,
            });
        }
        let Some(state) = self.geometry_state.as_mut() else {
            return Ok(());
        };
        for (k, g) in geometries.iter().enumerate() {
            if !g.motion.is_empty() || pose(k) != state.start[k] {
                state.moving[k] = true;
            }
        }
        let still: Vec<usize> = (0..geometries.len())
            .filter(|&k| !state.moving[k])
            .collect();
        let moving: Vec<usize> = (0..geometries.len()).filter(|&k| state.moving[k]).collect();
        let extent = state.extent;
        let mut parts = Vec::new();
        if !still.is_empty() {
            let file = match &state.still {
                Some((which, file)) if *which == still => file.clone(),
                _ => {
                    parts.push((still_file.to_string(), still.clone()));
                    state.still = Some((still.clone(), still_file.to_string()));
                    still_file.to_string()
                }
            };
            self.geometry.add(time, 0, &file);
        }
        if !moving.is_empty() {
            parts.push((moving_file.to_string(), moving));
            self.geometry.add(time, 1, moving_file);
        }
        for (file, which) in parts {
            let data = geometry::polydata(geometries, &which, extent);
            self.write_file(&file, &data, time)?;
        }
        Ok(())
    }
}

/// The box that infinite planes are cut to: the simulation domain (where particles can be), or
/// without one the particles and finite geometry grown by a tenth of their extent.
fn plane_extent(sim: &Simulation) -> (DVec3, DVec3) {
    if let Some(domain) = sim.params.domain {
        return domain;
    }
    let (mut lo, mut hi) = if sim.particles.is_empty() {
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY))
    } else {
        sim.particles.bounds(true)
    };
    for e in sim.geometries.iter().flat_map(|g| &g.elements) {
        let (a, b) = e.bounds();
        if a.is_finite() && b.is_finite() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        // Nothing finite at all: planes alone. A metre square shows them.
        return (DVec3::splat(-0.5), DVec3::splat(0.5));
    }
    let pad = DVec3::splat(0.1 * (hi - lo).max_element());
    (lo - pad, hi + pad)
}
