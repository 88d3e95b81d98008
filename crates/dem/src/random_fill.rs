//! Random fills: a mixture's particles at random positions and orientations in a box or a
//! cylinder, without overlap, avoiding the particles already there.
//!
//! Two phases, each O(N):
//!
//! 1. **Random insertion** (random sequential addition, as LIGGGHTS' `insert/pack`). Particles are
//!    drawn first and placed largest first; each gets up to [`ATTEMPTS`] random positions and
//!    orientations, and takes the first where every member sphere lies inside and overlaps no
//!    sphere placed before (a linked-list cell grid). A particle that finds no place waits for
//!    phase 2, and once the particles take more than [`STOP_AFTER`] attempts each on average, the
//!    rest wait too: the free room is then under a tenth of the region. Insertion alone stalls
//!    near a solid fraction of 0.3 for spheres (0.27 in a cylinder ten diameters across with 2 000
//!    attempts each; 0.38 in bulk after infinitely many).
//! 2. **Relaxation**, when some wait: each gets a random position and orientation clear of the
//!    particles already there, overlapping the fill's own, and every particle of the fill (a
//!    sphere, a polyhedron as its bounding sphere, a clump as a rigid body that translates without
//!    turning) is pushed apart from the others and from the particles already there (which stay
//!    put) until no two overlap ([`FILL_OVERLAP_TOLERANCE`]), with the region projected back
//!    before each pass (`packing.rs`: pair pushes to 0.5 % beyond touching over a Verlet
//!    list). Particles still overlapping after 200 passes without progress, when they are under
//!    1 % of the fill (caught among fixed ones, say; more are a jam), are put elsewhere and relaxed
//!    again, up to [`RETRIES`] times. The bodies are
//!    numbered in cell order first, so that a pass walks memory in order.
//!
//! Insertion is sequential and relaxation works slab by slab in an order set by the grid alone,
//! so a seed gives the same particles for any thread count. A fill asking for more than
//! [`MAX_FILL_SOLID_FRACTION`] of the region is refused before anything is placed; one that jams
//! below it says how far it got.
//!
//! Measured (test profile, 2 cores shared with other work): 1 800 spheres of 5 mm in a cylinder
//! 54 mm across and 192 mm tall (solid fraction 0.27) fill in under 10 ms for every seed 1-20,
//! 2 360 (0.35) in about 10 ms, 3 360 (0.50) in 60 ms, 3 897 (0.58) in about 1 s (1 500-3 300
//! passes); 4 031 (0.60) jam and are refused in about 0.6 s. The time grows linearly with the
//! count: at 0.35 in a box ([`fill_benchmark`]), 10 000 spheres take 0.05 s, 100 000 0.5 s and
//! a million 6-8 s (40 passes; two threads gain nothing while other work holds the cores).

use crate::fill::FillRegion;
use crate::mixture::{random_orientation, FillTarget, Item, Mixture, ParticleType, Shape};
use crate::packing::{self, Bodies, Relaxation};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// The largest overlap a fill ends with, as a fraction of the smaller radius of the pair: none,
/// to rounding, as insertion leaves them (and so a polyhedron, placed as its bounding sphere,
/// overlaps nothing either). Relaxing to this rather than to a stalk specimen's 0.5 % costs about
/// a tenth more passes.
pub const FILL_OVERLAP_TOLERANCE: f64 = 1e-9;

/// The largest solid fraction (particle volume, with the particles already in the region, over
/// the region's volume; a polyhedron counts as its bounding sphere) a fill tries. Random close
/// packing of equal spheres is 0.64 in bulk, less against walls, and relaxation without friction
/// slows down long before it.
pub const MAX_FILL_SOLID_FRACTION: f64 = 0.6;

/// Random positions tried for each particle in phase 1.
pub const ATTEMPTS: usize = 50;

/// Phase 1 stops when the particles take more attempts than this on average (over the last few
/// dozen): the free room is then under a tenth of the region, and relaxation places the rest for
/// less.
pub const STOP_AFTER: f64 = 10.0;
/// Relaxations after the first, each with the particles still overlapping moved elsewhere.
pub const RETRIES: usize = 3;

/// The attempts are averaged with a weight of 1 / MEAN_OVER for the latest.
const MEAN_OVER: f64 = 32.0;

/// The relaxation: radii at full size from the start, pairs pushed to 0.5 % beyond touching
/// (0.2 % takes a quarter more passes at a solid fraction of 0.35, 1 % twice the passes at
/// 0.58), a skin of a quarter of the smallest radius, slabs, stuck after 200 passes without
/// progress.
const RELAXATION: Relaxation = Relaxation {
    tolerance: FILL_OVERLAP_TOLERANCE,
    growth: 0.0,
    stall_passes: 200,
    aim_beyond: 0.005,
    skin: 0.25,
    slabs: true,
};

/// What a fill did.
#[derive(Clone, Debug, PartialEq)]
pub struct FillReport {
    /// Particles placed by random insertion; the others were relaxed into place.
    pub inserted: usize,
    /// Relaxation passes (0 when insertion placed every particle).
    pub passes: usize,
    /// The largest overlap left, a fraction of the smaller radius (0 after insertion alone).
    pub largest_overlap: f64,
    /// The particles' volume over the region's.
    pub solid_fraction: f64,
}

/// Seeded random fill of a mixture wholly inside `region`, avoiding `existing` spheres (see the
/// module notes).
pub fn fill_region(
    region: &FillRegion,
    mixture: &Mixture,
    target: FillTarget,
    seed: u64,
    existing: &[(DVec3, f64)],
) -> Result<Vec<Item>, String> {
    fill(region, mixture, target, seed, existing).map(|(items, _)| items)
}

/// The particle's own volume.
fn volume(t: &ParticleType, s: f64) -> f64 {
    match &t.shape {
        Shape::Sphere => 4.0 / 3.0 * PI * s.powi(3),
        Shape::Clump { props, .. } => props.volume * s.powi(3),
        Shape::Polyhedron { polyhedron } => polyhedron.volume * s.powi(3),
    }
}

/// The volume the fill packs: a polyhedron's bounding sphere, otherwise the particle's own.
fn packed_volume(t: &ParticleType, s: f64) -> f64 {
    match &t.shape {
        Shape::Polyhedron { polyhedron } => {
            4.0 / 3.0 * PI * (polyhedron.bounding_radius * s).powi(3)
        }
        _ => volume(t, s),
    }
}

/// [`fill_region`] with what it did.
pub fn fill(
    region: &FillRegion,
    mixture: &Mixture,
    target: FillTarget,
    seed: u64,
    existing: &[(DVec3, f64)],
) -> Result<(Vec<Item>, FillReport), String> {
    // A count that cannot fit even at the smallest size is refused before millions of
    // particles are drawn (9 999 999 in a small box took 1.6 s and 700 MB to refuse).
    if let FillTarget::Count(n) = target {
        let smallest = mixture
            .types
            .iter()
            .map(|t| packed_volume(t, t.size.min_radius()))
            .fold(f64::INFINITY, f64::min);
        let asked = n as f64 * smallest / region.volume();
        if asked.is_finite() && asked > MAX_FILL_SOLID_FRACTION {
            return Err(format!(
                "the region is too small: {n} particles would fill at least {:.1} % of it, and a random fill packs at most {:.0} %; expected fewer or smaller particles or a larger region",
                100.0 * asked,
                100.0 * MAX_FILL_SOLID_FRACTION
            ));
        }
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut items = mixture.draw_all(target, &mut rng)?;
    let bound = |it: &Item| {
        mixture.types[it.kind].bounding_radius() * it.size
            / mixture.types[it.kind].size.max_radius()
    };
    items.sort_by(|a, b| bound(b).total_cmp(&bound(a)));
    let n = items.len();
    let region_volume = region.volume();
    let solid: f64 = items
        .iter()
        .map(|it| volume(&mixture.types[it.kind], it.size))
        .sum();
    let requested = solid / region_volume;
    let mut report = FillReport {
        inserted: n,
        passes: 0,
        largest_overlap: 0.0,
        solid_fraction: requested,
    };
    if n == 0 {
        return Ok((items, report));
    }

    // Refuse what cannot fit before placing anything.
    let max_r = mixture.max_sphere_radius();
    let width = region.smallest_width();
    if 2.0 * max_r > width {
        return Err(format!(
            "the region is too small: it is {width} m across at its narrowest, and the particles hold spheres of radius up to {max_r} m; expected a larger region or smaller particles"
        ));
    }
    let (lo, hi) = region.bounds();
    let within = |x: DVec3, r: f64| {
        let reach = DVec3::splat(r + max_r);
        x.cmpge(lo - reach).all() && x.cmple(hi + reach).all()
    };
    let near: Vec<(DVec3, f64)> = existing
        .iter()
        .copied()
        .filter(|&(x, r)| within(x, r))
        .collect();
    let taken: f64 = near
        .iter()
        .filter(|(x, _)| region.contains(*x, 0.0))
        .map(|(_, r)| 4.0 / 3.0 * PI * r.powi(3))
        .sum();
    let packed: f64 = items
        .iter()
        .map(|it| packed_volume(&mixture.types[it.kind], it.size))
        .sum();
    let asked = (packed + taken) / region_volume;
    if asked > MAX_FILL_SOLID_FRACTION {
        let already = if taken > 0.0 {
            " with the particles already there"
        } else {
            ""
        };
        return Err(format!(
            "the region is too small: {n} particles would fill {:.1} % of it{already}, and a random fill packs at most {:.0} %; expected fewer or smaller particles or a larger region",
            100.0 * asked,
            100.0 * MAX_FILL_SOLID_FRACTION
        ));
    }

    // Phase 1: random insertion.
    let reach = near.iter().map(|e| e.1).fold(max_r, f64::max);
    let mut grid = InsertGrid::new(lo, hi, 2.0 * reach, n + near.len());
    for &(x, r) in &near {
        grid.insert(x, r);
    }
    let random_centre =
        |rng: &mut Pcg64| lo + (hi - lo) * DVec3::new(rng.gen(), rng.gen(), rng.gen());
    let mut members = Vec::new();
    let mut waiting = Vec::new();
    // Attempts per particle, averaged over the last few dozen.
    let mut mean_attempts = 1.0;
    for (k, item) in items.iter_mut().enumerate() {
        if mean_attempts > STOP_AFTER {
            waiting.push(k);
            continue;
        }
        let t = &mixture.types[item.kind];
        let mut placed = false;
        let mut tries = 0;
        for _ in 0..ATTEMPTS {
            tries += 1;
            let centre = random_centre(&mut rng);
            // Cheap rejection before looking at members.
            if !region.contains(centre, 0.0) {
                continue;
            }
            item.position = centre;
            item.orientation = random_orientation(&mut rng);
            t.spheres(item, &mut members);
            if members
                .iter()
                .all(|(x, r)| region.contains(*x, *r) && grid.is_free(*x, *r))
            {
                for (x, r) in &members {
                    grid.insert(*x, *r);
                }
                placed = true;
                break;
            }
        }
        mean_attempts += (tries as f64 - mean_attempts) / MEAN_OVER;
        if !placed {
            waiting.push(k);
        }
    }
    if waiting.is_empty() {
        return Ok((items, report));
    }
    report.inserted = n - waiting.len();

    // Phase 2: the rest anywhere in the region clear of the particles already there (overlaps
    // among the fill's own are relaxed away, but one caught among fixed particles might not get
    // out), then relaxation.
    let mut fixed = InsertGrid::new(lo, hi, 2.0 * reach, near.len());
    for &(x, r) in &near {
        fixed.insert(x, r);
    }
    // A random place in the region clear of the fixed particles (else the last of ATTEMPTS),
    // turned at random when `turn`.
    let spot = |item: &mut Item, turn: bool, rng: &mut Pcg64, members: &mut Vec<(DVec3, f64)>| {
        let t = &mixture.types[item.kind];
        let mut inside = 0;
        for _ in 0..1000 {
            let centre = random_centre(rng);
            if !region.contains(centre, 0.0) {
                continue;
            }
            item.position = centre;
            if turn {
                item.orientation = random_orientation(rng);
            }
            t.spheres(item, members);
            inside += 1;
            if inside == ATTEMPTS || members.iter().all(|(x, r)| fixed.is_free(*x, *r)) {
                break;
            }
        }
    };
    for &k in &waiting {
        spot(&mut items[k], true, &mut rng, &mut members);
    }
    let order = cell_order(&items, lo, 2.0 * max_r);
    let mut bodies = Bodies {
        position: Vec::with_capacity(n + near.len()),
        moves: Vec::with_capacity(n + near.len()),
        body: Vec::new(),
        offset: Vec::new(),
        radius: Vec::new(),
    };
    for &k in &order {
        mixture.types[items[k].kind].spheres(&items[k], &mut members);
        let b = bodies.position.len() as u32;
        for (x, r) in &members {
            bodies.body.push(b);
            bodies.offset.push(*x - items[k].position);
            bodies.radius.push(*r);
        }
        bodies.position.push(items[k].position);
        bodies.moves.push(true);
    }
    for &(x, r) in &near {
        bodies.body.push(bodies.position.len() as u32);
        bodies.offset.push(DVec3::ZERO);
        bodies.radius.push(r);
        bodies.position.push(x);
        bodies.moves.push(false);
    }
    let mut passes = 0;
    let mut round = 0;
    let overlapping = loop {
        let out = RELAXATION.run(&mut bodies, lo, hi, 1.0, |x, r| region.clamp(x, r));
        passes += out.passes;
        report.largest_overlap = out.largest_overlap;
        if out.done {
            break None;
        }
        let overlapping = packing::overlapping(&bodies, lo, hi, FILL_OVERLAP_TOLERANCE);
        let stuck = overlapping[..n].iter().filter(|&&o| o).count();
        if round == RETRIES || 100 * stuck > n {
            break Some(overlapping);
        }
        // A few particles caught where they cannot get out (more are a jam): elsewhere, and
        // relax again.
        for (b, &k) in order.iter().enumerate() {
            if overlapping[b] {
                spot(&mut items[k], false, &mut rng, &mut members);
                bodies.position[b] = items[k].position;
            }
        }
        round += 1;
    };
    report.passes = passes;
    if let Some(overlapping) = overlapping {
        let (mut placed, mut reached) = (0, 0.0);
        for (b, &k) in order.iter().enumerate() {
            if !overlapping[b] {
                placed += 1;
                reached += volume(&mixture.types[items[k].kind], items[k].size);
            }
        }
        return Err(format!(
            "the region is too small: placed only {placed} of {n} particles without overlap, a solid fraction of {:.3} of the {requested:.3} asked for (the others jam, overlapping by up to {:.2} % of a radius after {passes} passes); expected fewer or smaller particles or a larger region",
            reached / region_volume,
            100.0 * report.largest_overlap,
        ));
    }
    for (b, &k) in order.iter().enumerate() {
        items[k].position = bodies.position[b];
    }
    Ok((items, report))
}

/// The items' indices sorted by the cell (`cell` wide, from `lo`, z slowest) of their position.
fn cell_order(items: &[Item], lo: DVec3, cell: f64) -> Vec<usize> {
    let mut keyed: Vec<(u64, usize)> = items
        .iter()
        .enumerate()
        .map(|(k, it)| {
            let c = ((it.position - lo) / cell).floor().max(DVec3::ZERO);
            let key = (c.z as u64).min(0x1f_ffff) << 42
                | (c.y as u64).min(0x1f_ffff) << 21
                | (c.x as u64).min(0x1f_ffff);
            (key, k)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, k)| k).collect()
}

/// The spheres placed so far, for insertion: a grid of cells at least as wide as the largest
/// contact distance (wider where the region is large for its particles, so that there are at
/// most about four cells a sphere), each cell a linked list (a head per cell, a next per sphere),
/// so that adding a sphere is O(1) and a query looks at 27 cells. A sphere outside the grid
/// counts in its nearest cell.
struct InsertGrid {
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    head: Vec<u32>,
    /// Per sphere: centre, radius and the next sphere in its cell, together (one cache line).
    nodes: Vec<Node>,
}

struct Node {
    centre: DVec3,
    radius: f64,
    next: u32,
}

const NONE: u32 = u32::MAX;

impl InsertGrid {
    fn new(lo: DVec3, hi: DVec3, reach: f64, n: usize) -> InsertGrid {
        let mut cell = reach.max(((hi - lo).element_product() / (4.0 * n as f64 + 64.0)).cbrt());
        // A region absurdly large or thin would ask more cells than memory holds (a box to 1e308
        // overflowed the allocation): no side more than 2^20 cells, the grid at most 2^24.
        cell = cell.max((hi - lo).max_element() / (1u64 << 20) as f64);
        let mut d = ((hi - lo) / cell).ceil().max(DVec3::ONE);
        while d.element_product() > (1u64 << 24) as f64 {
            cell *= 2.0;
            d = ((hi - lo) / cell).ceil().max(DVec3::ONE);
        }
        let dims = [d.x as usize, d.y as usize, d.z as usize];
        InsertGrid {
            lo,
            cell,
            dims,
            head: vec![NONE; dims[0] * dims[1] * dims[2]],
            nodes: Vec::with_capacity(n),
        }
    }

    fn coords(&self, x: DVec3) -> [usize; 3] {
        let c = ((x - self.lo) / self.cell).floor().max(DVec3::ZERO);
        [
            (c.x as usize).min(self.dims[0] - 1),
            (c.y as usize).min(self.dims[1] - 1),
            (c.z as usize).min(self.dims[2] - 1),
        ]
    }

    fn insert(&mut self, x: DVec3, r: f64) {
        let [cx, cy, cz] = self.coords(x);
        let k = cx + self.dims[0] * (cy + self.dims[1] * cz);
        self.nodes.push(Node {
            centre: x,
            radius: r,
            next: self.head[k],
        });
        self.head[k] = (self.nodes.len() - 1) as u32;
    }

    /// Whether a sphere at x of radius r (at most the largest stored) overlaps none stored.
    fn is_free(&self, x: DVec3, r: f64) -> bool {
        let [cx, cy, cz] = self.coords(x);
        let [nx, ny, nz] = self.dims;
        for z in cz.saturating_sub(1)..(cz + 2).min(nz) {
            for y in cy.saturating_sub(1)..(cy + 2).min(ny) {
                for x0 in cx.saturating_sub(1)..(cx + 2).min(nx) {
                    let mut s = self.head[x0 + nx * (y + ny * z)];
                    while s != NONE {
                        let node = &self.nodes[s as usize];
                        let q = node.radius;
                        if (x - node.centre).length_squared() < (r + q) * (r + q) {
                            return false;
                        }
                        s = node.next;
                    }
                }
            }
        }
        true
    }
}

/// What [`fill_benchmark`] measured.
#[derive(Clone, Debug, PartialEq)]
pub struct FillBenchmark {
    pub count: usize,
    /// Sphere volume over the box's.
    pub solid_fraction: f64,
    /// Wall-clock seconds of the fill.
    pub seconds: f64,
    pub report: FillReport,
}

/// Fills a cube with `count` spheres of 2 mm at a solid fraction of 0.35 (seed 1) and times it.
pub fn fill_benchmark(count: usize) -> Result<FillBenchmark, String> {
    let r: f64 = 0.002;
    let fraction = 0.35;
    let side = (count as f64 * 4.0 / 3.0 * PI * r.powi(3) / fraction).cbrt();
    let region = FillRegion::Box {
        min: DVec3::ZERO,
        max: DVec3::splat(side),
    };
    let mixture = Mixture::single(ParticleType::sphere(
        "bead",
        0,
        1000.0,
        crate::fill::SizeDistribution::Fixed { radius: r },
    ));
    let started = std::time::Instant::now();
    let (items, report) = fill(&region, &mixture, FillTarget::Count(count), 1, &[])?;
    Ok(FillBenchmark {
        count: items.len(),
        solid_fraction: report.solid_fraction,
        seconds: started.elapsed().as_secs_f64(),
        report,
    })
}
