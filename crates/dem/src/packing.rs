//! Overlap relaxation, shared by random fills ([`crate::random_fill`]) and random stalk
//! specimens ([`crate::specimen`]).
//!
//! Spheres, or rigid bodies made of spheres that translate but never turn, are pushed apart pair
//! by pair until the largest overlap is below a tolerance, and put back into their region before
//! every pass. Each overlapping pair (and each pair closer than a hair beyond touching,
//! [`Relaxation::aim_beyond`]) moves apart along its line of centres to that hair beyond touching,
//! half each, or all of it for the one that moves when the other is fixed (a particle already in
//! the scene). Aiming beyond touching gets the overlaps below the tolerance in fewer passes than
//! an exact target, approached ever more slowly, would take. Pairs come from a Verlet list (a
//! counting-sorted cell grid, a skin of [`Relaxation::skin`] of the smallest radius, rebuilt when
//! bodies may have moved that far), so a pass is O(N). Pairs are visited in the grid's order and
//! each move is seen by the next pair (Gauss-Seidel), which halves the passes near jamming against
//! moves summed over a pass, and the order is fixed, so the result depends on the start alone.
//!
//! With [`Relaxation::slabs`] and bodies of one sphere each, the list is split into slabs of cell
//! layers and each rebuild renumbers the spheres in cell order (which also keeps a pass's memory
//! accesses in order): a pair touches its own slab and the next, so the even slabs can be relaxed
//! at once, on several threads, and then the odd ones. The slabs are set by the grid alone, so the
//! result is the same for any number of threads. Otherwise one thread walks the whole list.
//!
//! A radius scale below 1 grows by [`Relaxation::growth`] whenever the largest overlap is below the
//! tolerance, so a packing can start loose and densify. The relaxation stops when the scale is 1
//! and the largest overlap, checked over all pairs once the bodies are back in their region, is
//! below the tolerance, or when [`Relaxation::stall_passes`] passes bring no progress (jammed).

use glam::DVec3;
use rayon::prelude::*;

/// Spheres grouped into rigid bodies that translate during relaxation.
pub(crate) struct Bodies {
    pub position: Vec<DVec3>,
    /// Per body: whether it moves (a particle already placed does not).
    pub moves: Vec<bool>,
    /// Per sphere: its body, its centre relative to the body's position, its radius at scale 1.
    pub body: Vec<u32>,
    pub offset: Vec<DVec3>,
    pub radius: Vec<f64>,
}

impl Bodies {
    /// Free spheres, one body each, all moving.
    pub fn spheres(position: Vec<DVec3>, radius: Vec<f64>) -> Bodies {
        let n = position.len();
        Bodies {
            position,
            moves: vec![true; n],
            body: (0..n as u32).collect(),
            offset: vec![DVec3::ZERO; n],
            radius,
        }
    }

    /// Whether every body is one sphere at its position (sphere i is body i).
    fn single(&self) -> bool {
        let n = self.radius.len();
        self.position.len() == n
            && (0..n).all(|i| self.body[i] as usize == i && self.offset[i] == DVec3::ZERO)
    }

    fn centre(&self, i: usize) -> DVec3 {
        self.position[self.body[i] as usize] + self.offset[i]
    }

    /// Whether spheres i and j may be pushed apart: different bodies, not both fixed.
    fn pushable(&self, i: usize, j: usize) -> bool {
        let (a, b) = (self.body[i] as usize, self.body[j] as usize);
        a != b && (self.moves[a] || self.moves[b])
    }

    /// Moves each moving body so that each of its spheres in turn lies where `project` puts it.
    fn project(
        &mut self,
        single: bool,
        parallel: bool,
        scale: f64,
        project: &(impl Fn(DVec3, f64) -> DVec3 + Sync),
    ) {
        if single {
            let one = |((p, &r), &moves): ((&mut DVec3, &f64), &bool)| {
                if moves {
                    *p = project(*p, scale * r);
                }
            };
            let (p, r, m) = (&mut self.position, &self.radius, &self.moves);
            if parallel {
                p.par_iter_mut().zip(r).zip(m).for_each(one);
            } else {
                p.iter_mut().zip(r).zip(m).for_each(one);
            }
            return;
        }
        for i in 0..self.body.len() {
            let b = self.body[i] as usize;
            if self.moves[b] {
                let p = self.centre(i);
                let q = project(p, scale * self.radius[i]);
                if q != p {
                    self.position[b] = q - self.offset[i];
                }
            }
        }
    }

    /// Puts bodies of one sphere each in the order `order` (new index k is old `order[k]`).
    fn renumber(&mut self, order: &[u32]) {
        self.position = order.iter().map(|&k| self.position[k as usize]).collect();
        self.radius = order.iter().map(|&k| self.radius[k as usize]).collect();
        self.moves = order.iter().map(|&k| self.moves[k as usize]).collect();
    }
}

/// How a relaxation goes and when it stops.
pub(crate) struct Relaxation {
    /// The largest overlap wanted at the end, a fraction of the smaller radius of the pair.
    pub tolerance: f64,
    /// How much the radius scale grows in one step, as a fraction.
    pub growth: f64,
    /// Passes without progress after which the bodies are declared jammed.
    pub stall_passes: usize,
    /// Pairs are pushed apart to this fraction beyond touching.
    pub aim_beyond: f64,
    /// The pair list holds pairs up to this fraction of the smallest radius apart, and is rebuilt
    /// when spheres may have moved that far toward each other.
    pub skin: f64,
    /// Relax bodies of one sphere each slab by slab, in parallel (see the module notes).
    pub slabs: bool,
}

/// Where a relaxation ended.
pub(crate) struct Relaxed {
    /// Whether the scale reached 1 with every overlap below the tolerance.
    pub done: bool,
    pub passes: usize,
    pub scale: f64,
    /// The largest overlap as a fraction of the smaller radius (at the last pass, or over all
    /// pairs when done).
    pub largest_overlap: f64,
}

/// At most this many slabs, of whole cell layers.
const MAX_SLABS: usize = 32;
/// Fewer spheres than this are relaxed on one thread (the slabs are the same, and so is the
/// result): a pass over them takes less than starting threads does.
const PARALLEL_FROM: usize = 20_000;

/// A Verlet list in slabs: `pairs[s]` holds the pairs whose first sphere lies in slab s, and the
/// bodies of slab s are `bounds[s]..bounds[s + 1]`.
struct PairList {
    pairs: Vec<Vec<(u32, u32)>>,
    bounds: Vec<usize>,
}

impl Relaxation {
    /// Relaxes `bodies` in the box `lo..hi` (spheres outside it are still found, only slower),
    /// starting at radius scale `scale`; `project(x, r)` is the nearest place to x for a sphere of
    /// radius r in the region.
    pub fn run(
        &self,
        bodies: &mut Bodies,
        lo: DVec3,
        hi: DVec3,
        mut scale: f64,
        project: impl Fn(DVec3, f64) -> DVec3 + Sync,
    ) -> Relaxed {
        let n = bodies.radius.len();
        let r_max = bodies.radius.iter().cloned().fold(0.0, f64::max);
        let r_min = (0..n)
            .filter(|&i| bodies.moves[bodies.body[i] as usize])
            .map(|i| bodies.radius[i])
            .fold(f64::INFINITY, f64::min);
        let single = bodies.single();
        let slabbed = self.slabs && single;
        let parallel = n >= PARALLEL_FROM;
        // Where each body started, by its index now (renumbering moves them).
        let mut original: Vec<u32> = (0..bodies.position.len() as u32).collect();
        let mut grid = Grid::new(lo, hi - lo, n);
        let mut centres = vec![DVec3::ZERO; n];
        let mut list = PairList {
            pairs: Vec::new(),
            bounds: Vec::new(),
        };
        // Where each body was and the scale when the list was built; None: build it.
        let mut built: Option<(Vec<DVec3>, f64)> = None;
        let mut passes = 0;
        // Progress: the pass that last grew the scale or, at full scale, lowered the best overlap.
        let mut best = f64::INFINITY;
        let mut last_progress = 0;
        let outcome = loop {
            bodies.project(single, parallel, scale, &project);
            let skin = self.skin * scale * r_min;
            // Whether a pair not in the list may be in contact.
            let stale = |bodies: &Bodies, built: &Option<(Vec<DVec3>, f64)>| match built {
                None => true,
                Some((at, s)) => {
                    let moved = bodies
                        .position
                        .iter()
                        .zip(at)
                        .map(|(p, q)| (*p - *q).length_squared())
                        .fold(0.0, f64::max)
                        .sqrt();
                    // Two spheres approach by at most twice the largest move, and a growing scale
                    // adds to every contact distance.
                    2.0 * moved + 2.0 * (scale - s) * r_max > skin
                }
            };
            if stale(bodies, &built) {
                for (i, c) in centres.iter_mut().enumerate() {
                    *c = bodies.centre(i);
                }
                grid.sort(&centres, 2.0 * scale * r_max + skin);
                if slabbed {
                    original = grid.order.iter().map(|&k| original[k as usize]).collect();
                    bodies.renumber(&grid.order);
                    grid.renumber();
                    centres.copy_from_slice(&bodies.position);
                }
                let slabs = if slabbed {
                    grid.dims[2].min(MAX_SLABS)
                } else {
                    1
                };
                let (b, centres) = (&*bodies, &centres);
                list.pairs = grid.layer_pairs(slabs, parallel, |i, j| {
                    let reach = scale * (b.radius[i] + b.radius[j]) + skin;
                    (centres[i] - centres[j]).length_squared() < reach * reach
                        && if single {
                            b.moves[i] || b.moves[j]
                        } else {
                            b.pushable(i, j)
                        }
                });
                list.bounds = (0..slabs)
                    .map(|s| grid.layer_start(s * grid.dims[2] / slabs))
                    .chain([bodies.position.len()])
                    .collect();
                built = Some((bodies.position.clone(), scale));
            }
            let aim = 1.0 + self.aim_beyond;
            let largest = if single {
                list.pass::<false>(bodies, scale, aim, parallel)
            } else {
                list.pass::<true>(bodies, scale, aim, parallel)
            };
            if scale == 1.0 && largest < self.tolerance {
                // The pass measured the overlaps before its moves and moved only pairs closer than
                // aimed for; put the bodies back inside and check once more, with no moves.
                bodies.project(single, parallel, 1.0, &project);
                // Every pair in contact is in the list unless it is stale.
                let largest = if stale(bodies, &built) {
                    largest_overlap(bodies, &mut grid, &mut centres, parallel)
                } else {
                    list.largest_overlap(bodies)
                };
                if largest < self.tolerance {
                    break Relaxed {
                        done: true,
                        passes,
                        scale,
                        largest_overlap: largest,
                    };
                }
            }
            passes += 1;
            if scale == 1.0 && largest < 0.99 * best {
                best = largest;
                last_progress = passes;
            }
            if passes - last_progress > self.stall_passes {
                break Relaxed {
                    done: false,
                    passes,
                    scale,
                    largest_overlap: largest,
                };
            }
            if scale < 1.0 && largest < self.tolerance {
                scale = (scale * (1.0 + self.growth)).min(1.0);
                last_progress = passes;
            }
        };
        if slabbed {
            let mut back = vec![0u32; original.len()];
            for (k, &o) in original.iter().enumerate() {
                back[o as usize] = k as u32;
            }
            bodies.renumber(&back);
        }
        outcome
    }
}

impl PairList {
    /// The largest overlap of the pairs in the list (0 for none), as [`largest_overlap`] gives it.
    fn largest_overlap(&self, bodies: &Bodies) -> f64 {
        self.pairs
            .iter()
            .flatten()
            .map(|&(i, j)| {
                let (i, j) = (i as usize, j as usize);
                let (ri, rj) = (bodies.radius[i], bodies.radius[j]);
                (ri + rj - (bodies.centre(i) - bodies.centre(j)).length()) / ri.min(rj)
            })
            .fold(0.0, f64::max)
    }

    /// One pass; returns the largest overlap before the moves, as a fraction of the smaller radius
    /// of the pair. Slabs 0, 2, 4, ... first (each moves only its own bodies and the next slab's),
    /// then 1, 3, 5, ...
    fn pass<const RIGID: bool>(
        &self,
        bodies: &mut Bodies,
        scale: f64,
        aim: f64,
        parallel: bool,
    ) -> f64 {
        let Bodies {
            position,
            moves,
            body,
            offset,
            radius,
        } = bodies;
        let shape = Shape {
            moves,
            body,
            offset,
            radius,
        };
        let slabs = self.pairs.len();
        let mut largest = 0.0f64;
        for phase in 0..2.min(slabs) {
            let mut parts = Vec::new();
            let mut rest = &mut position[..];
            let mut at = 0;
            for s in (phase..slabs).step_by(2) {
                let (from, to) = (self.bounds[s], self.bounds[(s + 2).min(slabs)]);
                let (_, tail) = std::mem::take(&mut rest).split_at_mut(from - at);
                let (part, tail) = tail.split_at_mut(to - from);
                parts.push((part, from, &self.pairs[s]));
                (rest, at) = (tail, to);
            }
            let relax = |(part, from, pairs): (&mut [DVec3], usize, &Vec<(u32, u32)>)| {
                push_apart::<RIGID>(part, from, &shape, pairs, scale, aim)
            };
            let most = if parallel {
                parts.into_par_iter().map(relax).reduce(|| 0.0, f64::max)
            } else {
                parts.into_iter().map(relax).fold(0.0, f64::max)
            };
            largest = largest.max(most);
        }
        largest
    }
}

/// What a pass reads of the bodies.
struct Shape<'a> {
    moves: &'a [bool],
    body: &'a [u32],
    offset: &'a [DVec3],
    radius: &'a [f64],
}

/// Pushes the pairs apart, moving bodies `from..from + position.len()`; returns the largest
/// overlap before the moves, as a fraction of the smaller radius of the pair. `RIGID`: some body
/// has more than one sphere or an offset sphere (when none has, sphere i is body i and the pass
/// skips the look-ups).
fn push_apart<const RIGID: bool>(
    position: &mut [DVec3],
    from: usize,
    shape: &Shape,
    pairs: &[(u32, u32)],
    scale: f64,
    aim: f64,
) -> f64 {
    let mut largest = 0.0f64;
    for &(i, j) in pairs {
        let (i, j) = (i as usize, j as usize);
        let (ri, rj) = (shape.radius[i], shape.radius[j]);
        let contact = scale * (ri + rj);
        let aim = contact * aim;
        let (a, b) = if RIGID {
            (shape.body[i] as usize, shape.body[j] as usize)
        } else {
            (i, j)
        };
        let d = if RIGID {
            (position[b - from] + shape.offset[j]) - (position[a - from] + shape.offset[i])
        } else {
            position[b - from] - position[a - from]
        };
        let dist2 = d.length_squared();
        if dist2 >= aim * aim {
            continue;
        }
        let dist = dist2.sqrt();
        // Coincident centres (rare: a projection onto the same wall point) part along x.
        let normal = if dist > 0.0 { d / dist } else { DVec3::X };
        largest = largest.max((contact - dist) / (scale * ri.min(rj)));
        match (shape.moves[a], shape.moves[b]) {
            (true, true) => {
                let half_push = 0.5 * (aim - dist) * normal;
                position[a - from] -= half_push;
                position[b - from] += half_push;
            }
            (true, false) => position[a - from] -= (aim - dist) * normal,
            _ => position[b - from] += (aim - dist) * normal,
        }
    }
    largest
}

/// The largest overlap of any two bodies, as a fraction of the smaller radius of the pair, at
/// scale 1 (0 for none).
fn largest_overlap(bodies: &Bodies, grid: &mut Grid, centres: &mut [DVec3], parallel: bool) -> f64 {
    for (i, c) in centres.iter_mut().enumerate() {
        *c = bodies.centre(i);
    }
    let r_max = bodies.radius.iter().cloned().fold(0.0, f64::max);
    grid.sort(centres, 2.0 * r_max);
    let nz = grid.dims[2];
    let parts = (4 * rayon::current_num_threads()).min(nz);
    let centres = &*centres;
    let worst = map_parts(parallel, parts, |p| {
        let mut worst = 0.0f64;
        grid.pairs_in_layers(p * nz / parts..(p + 1) * nz / parts, |i, j| {
            if bodies.pushable(i, j) {
                let (ri, rj) = (bodies.radius[i], bodies.radius[j]);
                let overlap = ri + rj - (centres[i] - centres[j]).length();
                worst = worst.max(overlap / ri.min(rj));
            }
        });
        worst
    });
    worst.into_iter().fold(0.0, f64::max)
}

/// Per body: whether it overlaps another by more than `tolerance` of the smaller radius.
pub(crate) fn overlapping(bodies: &Bodies, lo: DVec3, hi: DVec3, tolerance: f64) -> Vec<bool> {
    let n = bodies.radius.len();
    let centres: Vec<DVec3> = (0..n).map(|i| bodies.centre(i)).collect();
    let r_max = bodies.radius.iter().cloned().fold(0.0, f64::max);
    let mut grid = Grid::new(lo, hi - lo, n);
    grid.sort(&centres, 2.0 * r_max);
    let mut out = vec![false; bodies.position.len()];
    grid.for_each_pair(|i, j| {
        let (ri, rj) = (bodies.radius[i], bodies.radius[j]);
        if bodies.pushable(i, j)
            && ri + rj - (centres[i] - centres[j]).length() > tolerance * ri.min(rj)
        {
            out[bodies.body[i] as usize] = true;
            out[bodies.body[j] as usize] = true;
        }
    });
    out
}

/// `f(0), f(1), ..., f(n - 1)`, on several threads when `parallel`.
fn map_parts<T: Send>(parallel: bool, n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    if parallel {
        (0..n).into_par_iter().map(f).collect()
    } else {
        (0..n).map(f).collect()
    }
}

/// A cell grid over a box, counting-sorted each time it is used: cells at least as wide as the
/// largest contact distance, and never more cells than about twice the spheres (a sparse
/// packing gets wider cells), so a sort is O(N) in time and memory. Spheres outside the box
/// count in its edge cells.
pub(crate) struct Grid {
    lo: DVec3,
    extent: DVec3,
    max_cells: f64,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    order: Vec<u32>,
    cell_of: Vec<u32>,
}

impl Grid {
    /// A grid over the box from `lo` with sides `extent`, for `n` spheres.
    pub fn new(lo: DVec3, extent: DVec3, n: usize) -> Grid {
        Grid {
            lo,
            extent,
            max_cells: 2.0 * n as f64 + 27.0,
            cell: 0.0,
            dims: [1; 3],
            start: Vec::new(),
            order: vec![0; n],
            cell_of: vec![0; n],
        }
    }

    fn coord(&self, x: f64, lo: f64, dim: usize) -> usize {
        (((x - lo) / self.cell).floor().max(0.0) as usize).min(dim - 1)
    }

    /// Sorts `positions` into cells at least `reach` wide.
    pub fn sort(&mut self, positions: &[DVec3], reach: f64) {
        let volume = self.extent.element_product();
        self.cell = reach.max((volume / self.max_cells).cbrt());
        let d = (self.extent / self.cell).floor().max(DVec3::ONE);
        self.dims = [d.x as usize, d.y as usize, d.z as usize];
        let cells = self.dims[0] * self.dims[1] * self.dims[2];
        self.start.clear();
        self.start.resize(cells + 1, 0);
        for (k, p) in positions.iter().enumerate() {
            let c = self.coord(p.x, self.lo.x, self.dims[0])
                + self.dims[0]
                    * (self.coord(p.y, self.lo.y, self.dims[1])
                        + self.dims[1] * self.coord(p.z, self.lo.z, self.dims[2]));
            self.cell_of[k] = c as u32;
            self.start[c + 1] += 1;
        }
        for c in 0..cells {
            self.start[c + 1] += self.start[c];
        }
        let mut fill = self.start.clone();
        for (k, &c) in self.cell_of.iter().enumerate() {
            self.order[fill[c as usize] as usize] = k as u32;
            fill[c as usize] += 1;
        }
    }

    /// After the spheres were put in the sorted order: sphere k is the k-th.
    fn renumber(&mut self) {
        for (k, o) in self.order.iter_mut().enumerate() {
            *o = k as u32;
        }
    }

    /// The place in the sorted order of the first sphere of cell layer `z`.
    fn layer_start(&self, z: usize) -> usize {
        self.start[self.dims[0] * self.dims[1] * z] as usize
    }

    /// Calls `f(i, j)` once for every pair in the same or neighbouring cells.
    pub fn for_each_pair(&self, f: impl FnMut(usize, usize)) {
        self.pairs_in_layers(0..self.dims[2], f);
    }

    /// The pairs for which `keep(i, j)`, in the order [`Self::for_each_pair`] gives them, in
    /// `parts` lists of whole cell layers (by the layer of i); found in parallel, so that the
    /// lists are the same for any number of threads.
    fn layer_pairs(
        &self,
        parts: usize,
        parallel: bool,
        keep: impl Fn(usize, usize) -> bool + Sync,
    ) -> Vec<Vec<(u32, u32)>> {
        let nz = self.dims[2];
        // Each part in pieces, so that one thread does not wait for one large part.
        let pieces = (4 * rayon::current_num_threads()).div_ceil(parts).max(1);
        let layers = |p: usize, q: usize| {
            let (from, to) = (p * nz / parts, (p + 1) * nz / parts);
            from + q * (to - from) / pieces..from + (q + 1) * (to - from) / pieces
        };
        let found = map_parts(parallel, parts * pieces, |k| {
            let mut part = Vec::new();
            self.pairs_in_layers(layers(k / pieces, k % pieces), |i, j| {
                if keep(i, j) {
                    part.push((i as u32, j as u32));
                }
            });
            part
        });
        found.chunks(pieces).map(|c| c.concat()).collect()
    }

    /// [`Self::for_each_pair`] for the cells of layers `zs` (with their neighbours above).
    fn pairs_in_layers(&self, zs: std::ops::Range<usize>, mut f: impl FnMut(usize, usize)) {
        let [nx, ny, nz] = self.dims;
        let range = |x0: usize, x1: usize, y: usize, z: usize| {
            let row = nx * (y + ny * z);
            &self.order[self.start[row + x0] as usize..self.start[row + x1 + 1] as usize]
        };
        for cz in zs {
            for cy in 0..ny {
                for cx in 0..nx {
                    let own = range(cx, cx, cy, cz);
                    for (a, &i) in own.iter().enumerate() {
                        for &j in &own[a + 1..] {
                            f(i as usize, j as usize);
                        }
                    }
                    if own.is_empty() {
                        continue;
                    }
                    // The 13 neighbours after this cell in index order: the next in its row, and
                    // three cells (fewer at the edges) of each of four rows further on, each three
                    // contiguous in the sorted order.
                    let next = if cx + 1 < nx {
                        range(cx + 1, cx + 1, cy, cz)
                    } else {
                        &[]
                    };
                    let (x0, x1) = (cx.saturating_sub(1), (cx + 1).min(nx - 1));
                    let rows = [
                        (cy + 1, cz),
                        (cy.wrapping_sub(1), cz + 1),
                        (cy, cz + 1),
                        (cy + 1, cz + 1),
                    ];
                    for &i in own {
                        for &j in next {
                            f(i as usize, j as usize);
                        }
                        for &(y, z) in &rows {
                            if y < ny && z < nz {
                                for &j in range(x0, x1, y, z) {
                                    f(i as usize, j as usize);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
