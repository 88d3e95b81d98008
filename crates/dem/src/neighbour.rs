//! Neighbour search: a cell grid, cell-ordered particles, and Verlet lists with a skin.
//!
//! At each rebuild the particles are sorted by cell (counting sort) so that neighbours sit close in
//! memory, then the half pair list (i < j) is rebuilt as CSR rows. Because particles are in cell order
//! and the 27 neighbour cells are visited in increasing cell index, each row comes out sorted by j,
//! which lets the contact history move from the old list to the new one by a merge. A reverse index
//! (pairs in which a particle is j) lets forces be summed per particle without atomics.

use crate::contact::ContactHistory;
use crate::parallel;
use crate::particles::Particles;
use glam::DVec3;
use rayon::prelude::*;

/// One candidate pair with its contact history.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    /// Whatever the contact law keeps from step to step, seen from i.
    pub history: ContactHistory,
}

/// What one pair contributes this step, written by the pair phase and summed by the particle phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct PairOutput {
    /// Force on i (j gets the opposite).
    pub force: DVec3,
    pub torque_i: DVec3,
    pub torque_j: DVec3,
    /// Constant-directional rolling torque magnitudes for i and j.
    pub rolling_i: f64,
    pub rolling_j: f64,
}

/// Pairs per task of the pair stage, and per stretch of [`NearList::slots`] (so a chunk-local index
/// fits a u16).
pub const PAIR_CHUNK: usize = 1024;

/// The listed pairs that may touch before the particles have moved much: those closer than
/// `margin` (beyond touching, or beyond a cohesive law's reach) when the pair stage last went
/// over every pair. While no particle has moved half the margin since that scan, no other
/// pair can touch, so the pair stage visits only these; the others stay cleared, exactly as a
/// pass over them would leave them, so the results are the same bits. In a formed bed most
/// listed pairs are a skin's fraction apart and stay so: the near pairs are about the
/// touching ones.
///
/// Like the list itself, it assumes that between scans only positions change (radii,
/// materials, clump membership and the contact law stay as they were), and that they change
/// only where the integration measures them. Each measurement serves one pair stage: the stage
/// sets `moved` back to infinite, so a pair stage that no integration preceded goes over every
/// pair.
#[derive(Clone, Debug)]
pub struct NearList {
    /// The gap (m) below which the scan kept a pair (the pair stage takes it from
    /// [`crate::sim::SimulationParams::near_margin_fraction`]; 0: no near list).
    pub margin: f64,
    /// For each chunk of [`PAIR_CHUNK`] pairs, the chunk-local indices of its near pairs, at the
    /// start of the chunk's own stretch (`counts` of them).
    pub slots: Vec<u16>,
    pub counts: Vec<u32>,
    /// Positions at the scan.
    pub anchor: Vec<DVec3>,
    /// Whether `slots` hold a scan of the current pairs (a rebuild, or a stage that writes output
    /// slots and calls [`NeighbourList::mark_all_active`], clears it).
    pub current: bool,
    /// The largest displacement of any particle since the scan: the integration measures it
    /// against `anchor`, the pipeline sets it here, and the pair stage that uses it sets it back
    /// to infinite.
    pub moved: f64,
    /// Pair stages that went over every pair, and over the near pairs only.
    pub full_passes: u64,
    pub near_passes: u64,
}

impl Default for NearList {
    fn default() -> Self {
        NearList {
            margin: 0.0,
            slots: Vec::new(),
            counts: Vec::new(),
            anchor: Vec::new(),
            current: false,
            moved: f64::INFINITY,
            full_passes: 0,
            near_passes: 0,
        }
    }
}

impl NearList {
    /// Whether the pair stage may visit the near pairs only: no particle has moved half the
    /// margin since the scan, so no two have closed the margin between them (with a little to
    /// spare for the rounding of the distances).
    pub fn usable(&self) -> bool {
        self.current && self.moved < 0.49 * self.margin
    }

    /// The positions to measure the displacement against, while there is a scan.
    pub fn anchor(&self) -> Option<&[DVec3]> {
        self.current.then_some(&self.anchor[..])
    }
}

#[derive(Default)]
pub struct NeighbourList {
    pub skin: f64,
    pub pairs: Vec<Pair>,
    pub output: Vec<PairOutput>,
    /// Per pair, 0 when its output slot is zero and its history empty (the pair has been apart
    /// since the last build, or since it last touched), so that the pair and sum stages pass it
    /// by without touching either: while a bed forms most listed pairs are apart, and their
    /// slots are most of the memory traffic of a step. A stage that writes output slots without
    /// keeping this up to date calls [`NeighbourList::mark_all_active`].
    pub active: Vec<u8>,
    /// CSR rows over i into `pairs`.
    pub row_start: Vec<u32>,
    /// CSR rows over j into `reverse`, which holds pair indices.
    pub reverse_start: Vec<u32>,
    pub reverse: Vec<u32>,
    /// Positions at the last build, for the displacement check.
    pub built_at: Vec<DVec3>,
    /// The pairs the pair stage visits between full passes (see [`NearList`]).
    pub near: NearList,
    pub rebuilds: u64,
    // Reused buffers.
    keys: Vec<u64>,
    cell_start: Vec<u32>,
    order: Vec<u32>,
    inverse: Vec<u32>,
    scratch: Vec<u64>,
    carried: Vec<(u64, ContactHistory)>,
    grid: Grid,
}

#[derive(Default, Clone, Copy)]
struct Grid {
    lo: DVec3,
    inv_cell: f64,
    dims: [i64; 3],
}

impl Grid {
    #[inline(always)]
    fn coords(&self, x: DVec3) -> [i64; 3] {
        let c = (x - self.lo) * self.inv_cell;
        [
            (c.x as i64).clamp(0, self.dims[0] - 1),
            (c.y as i64).clamp(0, self.dims[1] - 1),
            (c.z as i64).clamp(0, self.dims[2] - 1),
        ]
    }

    #[inline(always)]
    fn index(&self, c: [i64; 3]) -> usize {
        (c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])) as usize
    }
}

/// The permutation applied to particles at a rebuild: `order[new] = old`, `inverse[old] = new`.
pub struct Reorder<'a> {
    pub order: &'a [u32],
    pub inverse: &'a [u32],
}

impl NeighbourList {
    /// Marks every pair as possibly non-zero (after its output slots were written by code that
    /// does not keep [`NeighbourList::active`]), so the sums read them all.
    pub fn mark_all_active(&mut self) {
        self.active.clear();
        self.active.resize(self.pairs.len(), 1);
        self.near.current = false;
    }

    pub fn new(skin: f64) -> Self {
        NeighbourList {
            skin,
            ..Default::default()
        }
    }

    /// Sorts particles by cell and rebuilds the pair list, carrying contact history across.
    /// `extra_reach` widens the search for models that act beyond touching (cohesion).
    /// Returns the permutation so the caller can move its own per-particle data.
    pub fn rebuild(&mut self, particles: &mut Particles, extra_reach: f64) -> Reorder<'_> {
        let n = particles.len();
        let max_r = parallel::max(&particles.radius);
        let reach = 2.0 * max_r + self.skin + extra_reach;

        // Grid over the particle bounds, coarsened if the particles are spread thinly.
        let (lo, hi) = if n == 0 {
            (DVec3::ZERO, DVec3::ZERO)
        } else {
            particles.bounds(false)
        };
        let ext = (hi - lo).max(DVec3::splat(1e-12));
        let mut cell = reach.max(1e-12);
        let max_cells = (8 * n + 64) as f64;
        while (ext.x / cell + 1.0) * (ext.y / cell + 1.0) * (ext.z / cell + 1.0) > max_cells {
            cell *= 1.26;
        }
        self.grid = Grid {
            lo,
            inv_cell: 1.0 / cell,
            dims: [
                (ext.x / cell) as i64 + 1,
                (ext.y / cell) as i64 + 1,
                (ext.z / cell) as i64 + 1,
            ],
        };
        let grid = self.grid;
        let ncell = (grid.dims[0] * grid.dims[1] * grid.dims[2]) as usize;

        // Sort by cell: every stage of the rebuild is parallel, and each gives the same answer
        // for any thread count (sort keys are unique, writes go to disjoint slots).
        self.keys.clear();
        self.keys.par_extend(
            particles
                .position
                .par_iter()
                .enumerate()
                .map(|(i, &x)| ((grid.index(grid.coords(x)) as u64) << 32) | i as u64),
        );
        self.keys.par_sort_unstable();
        self.cell_start.resize(ncell + 1, 0);
        let keys = &self.keys;
        parallel::row_starts(n, |k| (keys[k] >> 32) as usize, &mut self.cell_start);
        self.order.clear();
        self.order
            .par_extend(self.keys.par_iter().map(|&k| k as u32));
        self.inverse.resize(n, 0);
        let inverse = parallel::Shared(self.inverse.as_mut_ptr());
        self.order.par_iter().enumerate().for_each(|(new, &old)| {
            // SAFETY: `order` is a permutation, so every old index is written once.
            unsafe { inverse.ptr().add(old as usize).write(new as u32) };
        });
        particles.permute(&self.order, &mut self.scratch);

        // Old history, renamed to the new indices and sorted like the new list will be.
        let inverse = &self.inverse;
        self.carried.clear();
        self.carried.par_extend(
            self.pairs
                .par_iter()
                .filter(|p| !p.history.is_empty())
                .map(|p| {
                    let (a, b) = (inverse[p.i as usize], inverse[p.j as usize]);
                    if a < b {
                        ((a as u64) << 32 | b as u64, p.history)
                    } else {
                        ((b as u64) << 32 | a as u64, p.history.reversed())
                    }
                }),
        );
        self.carried.par_sort_unstable_by_key(|c| c.0);

        // New half list, found in parallel over blocks of particles, then written in parallel
        // at each block's offset.
        let skin = self.skin + extra_reach;
        let pos = &particles.position;
        let rad = &particles.radius;
        let cell_start = &self.cell_start;
        let block = 1024;
        let blocks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(block))
            .into_par_iter()
            .map(|b| {
                let lo_i = b * block;
                let hi_i = ((b + 1) * block).min(n);
                let mut counts = Vec::with_capacity(hi_i - lo_i);
                let mut js = Vec::with_capacity((hi_i - lo_i) * 8);
                for i in lo_i..hi_i {
                    let before = js.len();
                    let xi = pos[i];
                    let ri = rad[i];
                    let c = grid.coords(xi);
                    for dz in -1..=1 {
                        let z = c[2] + dz;
                        if z < 0 || z >= grid.dims[2] {
                            continue;
                        }
                        for dy in -1..=1 {
                            let y = c[1] + dy;
                            if y < 0 || y >= grid.dims[1] {
                                continue;
                            }
                            let x0 = (c[0] - 1).max(0);
                            let x1 = (c[0] + 1).min(grid.dims[0] - 1);
                            // Cells x0..=x1 of one row are contiguous, so scan them as one range.
                            let first = grid.index([x0, y, z]);
                            let last = grid.index([x1, y, z]);
                            let start = (cell_start[first] as usize).max(i + 1);
                            let end = cell_start[last + 1] as usize;
                            for j in start..end {
                                let cut = ri + rad[j] + skin;
                                if (pos[j] - xi).length_squared() < cut * cut {
                                    js.push(j as u32);
                                }
                            }
                        }
                    }
                    counts.push((js.len() - before) as u32);
                }
                (counts, js)
            })
            .collect();
        let mut offsets = Vec::with_capacity(blocks.len() + 1);
        offsets.push(0usize);
        for (_, js) in &blocks {
            offsets.push(offsets.last().unwrap() + js.len());
        }
        let total = *offsets.last().unwrap();
        self.pairs.resize(total, Pair::default());
        self.row_start.resize(n + 1, 0);
        self.row_start[n] = total as u32;
        let (pairs, rows) = (
            parallel::Shared(self.pairs.as_mut_ptr()),
            parallel::Shared(self.row_start.as_mut_ptr()),
        );
        let carried = &self.carried;
        blocks.par_iter().enumerate().for_each(|(b, (counts, js))| {
            let mut at = offsets[b];
            // The carried history of this block's rows: a merge, both sorted by (i, j).
            let first_key = ((b * block) as u64) << 32;
            let mut c = carried.partition_point(|h| h.0 < first_key);
            let mut k = 0;
            for (r, &count) in counts.iter().enumerate() {
                let i = (b * block + r) as u32;
                // SAFETY: row i and the pairs at offsets[b].. belong to this block alone.
                unsafe { rows.ptr().add(i as usize).write(at as u32) };
                for &j in &js[k..k + count as usize] {
                    let key = (i as u64) << 32 | j as u64;
                    while c < carried.len() && carried[c].0 < key {
                        c += 1;
                    }
                    let history = if c < carried.len() && carried[c].0 == key {
                        carried[c].1
                    } else {
                        ContactHistory::default()
                    };
                    unsafe { pairs.ptr().add(at).write(Pair { i, j, history }) };
                    at += 1;
                }
                k += count as usize;
            }
        });
        if n == 0 {
            self.row_start[0] = 0;
        }

        // Reverse index: for each j, the pairs it belongs to, in pair order (sorting the unique
        // keys (j, pair) gives exactly that).
        self.keys.clear();
        self.keys.par_extend(
            self.pairs
                .par_iter()
                .enumerate()
                .map(|(k, p)| (p.j as u64) << 32 | k as u64),
        );
        self.keys.par_sort_unstable();
        self.reverse_start.resize(n + 1, 0);
        let keys = &self.keys;
        parallel::row_starts(
            keys.len(),
            |k| (keys[k] >> 32) as usize,
            &mut self.reverse_start,
        );
        self.reverse.clear();
        self.reverse
            .par_extend(self.keys.par_iter().map(|&k| k as u32));
        self.output.clear();
        self.output
            .par_extend((0..total).into_par_iter().map(|_| PairOutput::default()));
        self.active.clear();
        self.active.par_extend(
            self.pairs
                .par_iter()
                .map(|p| u8::from(!p.history.is_empty())),
        );
        self.built_at.clear();
        self.built_at
            .par_extend(particles.position.par_iter().copied());
        self.near.current = false;
        self.rebuilds += 1;
        Reorder {
            order: &self.order,
            inverse: &self.inverse,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history_of(nl: &NeighbourList, p: &Particles, a: u32, b: u32) -> DVec3 {
        let pair = nl
            .pairs
            .iter()
            .find(|q| {
                let ids = (p.id[q.i as usize], p.id[q.j as usize]);
                ids == (a, b) || ids == (b, a)
            })
            .expect("pair listed");
        if p.id[pair.i as usize] == a {
            pair.history.tangential
        } else {
            -pair.history.tangential
        }
    }

    #[test]
    fn history_follows_the_pair_when_particles_are_reordered() {
        let mut p = Particles::default();
        p.push(DVec3::new(0.0, 0.0, 0.0), DVec3::ZERO, 0.001, 1000.0, 0);
        p.push(DVec3::new(0.0019, 0.0, 0.0), DVec3::ZERO, 0.001, 1000.0, 0);
        p.push(DVec3::new(0.05, 0.0, 0.0), DVec3::ZERO, 0.001, 1000.0, 0);
        let mut nl = NeighbourList::new(0.0002);
        nl.rebuild(&mut p, 0.0);
        assert_eq!(nl.pairs.len(), 1);
        let k = nl.pairs.iter().position(|_| true).unwrap();
        let sign = if p.id[nl.pairs[k].i as usize] == 0 {
            1.0
        } else {
            -1.0
        };
        nl.pairs[k].history.tangential = sign * DVec3::new(0.0, 1e-6, 0.0);
        assert_eq!(history_of(&nl, &p, 0, 1), DVec3::new(0.0, 1e-6, 0.0));

        // Move particle 1 to the other side of 0 and particle 2 far to the left: the cell sort
        // now puts them in the opposite order.
        for k in 0..3 {
            match p.id[k] {
                1 => p.position[k].x = -0.0019,
                2 => p.position[k].x = -0.05,
                _ => {}
            }
        }
        let before: Vec<u32> = p.id.clone();
        nl.rebuild(&mut p, 0.0);
        assert_ne!(before, p.id, "the rebuild reordered the particles");
        assert_eq!(history_of(&nl, &p, 0, 1), DVec3::new(0.0, 1e-6, 0.0));
        assert_eq!(history_of(&nl, &p, 1, 0), DVec3::new(0.0, -1e-6, 0.0));
    }

    #[test]
    fn half_list_holds_every_close_pair_once() {
        let mut p = Particles::default();
        let mut k = 0u64;
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    k = k
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let jitter = (k >> 40) as f64 / (1u64 << 24) as f64 * 0.0005;
                    p.push(
                        DVec3::new(x as f64, y as f64, z as f64) * 0.0021 + DVec3::splat(jitter),
                        DVec3::ZERO,
                        0.001,
                        1000.0,
                        0,
                    );
                }
            }
        }
        let mut nl = NeighbourList::new(0.0003);
        nl.rebuild(&mut p, 0.0);
        let n = p.len();
        let mut brute = 0;
        for i in 0..n {
            for j in i + 1..n {
                if (p.position[i] - p.position[j]).length() < 0.0023 {
                    brute += 1;
                }
            }
        }
        assert_eq!(nl.pairs.len(), brute);
        for w in nl.pairs.windows(2) {
            assert!((w[0].i, w[0].j) < (w[1].i, w[1].j), "rows sorted by (i, j)");
        }
    }
}
