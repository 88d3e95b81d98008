//! The device buffers of one try of a batch of worlds: their sizes, counted before they are made
//! (for the packing to the device's memory), and the buffers themselves, made in error scopes
//! from the context's pool or anew.

use super::bodies::BodyBuffers;
use super::bonds::BondBuffers;
use super::world::{Merged, World};
use super::{Capacity, Retry, BUCKETS_PER_PARTICLE, EMPTY};
use crate::layout;
use crate::pack::Counts;
use crate::{GpuContext, STATE_BYTES};

/// The sizes of one try.
pub(super) struct Sizes {
    /// Particles, pair slots, wall candidate slots and cell buckets of all the worlds.
    pub(super) n: usize,
    pub(super) pairs: usize,
    pub(super) walls: usize,
    pub(super) buckets: usize,
    /// The longest world's steps.
    pub(super) steps: usize,
    pub(super) geometries: usize,
    pub(super) elements: usize,
}

impl Sizes {
    pub(super) fn of(worlds: &[World], cap: Capacity) -> Sizes {
        let n: usize = worlds.iter().map(|w| w.n).sum();
        Sizes {
            n,
            pairs: n * cap.pair,
            walls: n * cap.wall,
            buckets: (BUCKETS_PER_PARTICLE * n).next_power_of_two().max(64),
            steps: worlds.iter().map(|w| w.steps).max().unwrap_or(0) as usize,
            geometries: worlds.iter().map(|w| w.geometry_first.len()).sum(),
            elements: worlds
                .iter()
                .map(|w| w.elements.len() / layout::element::LEN)
                .sum(),
        }
    }

    /// The largest buffer of the run, named, and its bytes (each must fit one binding), but for
    /// the pair and wall histories and the wall outputs, which are split across bindings
    /// ([`Split`]).
    pub(super) fn largest(&self, m: &Merged, cap: Capacity) -> (&'static str, usize) {
        [
            ("particle states", STATE_BYTES * self.n),
            ("forced rebuilds", 4 * (self.steps + 1)),
            ("element poses", 8 * m.element_track.len()),
            ("geometry poses", 8 * m.geoms_track.len()),
            ("material pairs", 8 * m.table.len()),
            ("pair slots", 4 * layout::pair_ij::LEN * self.pairs),
            ("wall candidates", 4 * layout::cands::LEN * self.walls),
            (
                "rows",
                4 * (layout::rows::REVERSE_ENTRIES * self.n + self.pairs),
            ),
            ("cell buckets", 4 * self.buckets * cap.bucket),
            ("elements", 8 * layout::element::LEN * self.elements),
        ]
        .into_iter()
        .chain(m.bonds.as_ref().map(|b| ("bonds", b.largest())))
        .chain(m.bodies.as_ref().map(|b| ("clump bodies", b.largest())))
        .max_by_key(|l| l.1)
        .unwrap_or(("lists", 0))
    }
}

/// Room for the small buffers of a try (counts, dimensions, control words, dispatch arguments),
/// which [`Sizes::bytes`] does not count one by one.
const SMALL_BUFFERS: u64 = 64 * 1024;

impl Sizes {
    /// The numbers of the lists bound in parts ([`Split`]), each with what it is called in a
    /// decline: the pair histories (in each of three lists), the wall outputs and the wall
    /// histories (in each of two).
    pub(super) fn split_lists(&self) -> [(&'static str, usize); 3] {
        [
            ("pair histories", layout::history::LEN * self.pairs),
            ("wall outputs", layout::wall_output::LEN * self.walls),
            ("wall histories", layout::history::LEN * self.walls),
        ]
    }

    /// The device memory the buffers of a try take, in bytes: [`Buffers::new`]'s buffers, the
    /// uploaded ones by their data and the others by their sizes, plus [`SMALL_BUFFERS`]. Each
    /// try checks it against the buffers made (`try_run`: a miscount is a decline).
    pub(super) fn bytes(&self, m: &Merged, cap: Capacity, worlds: usize) -> u64 {
        use layout::{cands, history, pair_ij, wall_output};
        let f64s = |len: usize| 8 * len.max(1);
        let u32s = |len: usize| 4 * len.max(2);
        let (n, pairs, walls) = (self.n, self.pairs, self.walls);
        let particles = f64s(m.state.len())
            + f64s(m.loads.len())
            + f64s(m.props.len())
            + u32s(m.ints.len())
            + u32s(n)
            + f64s(3 * n)
            + f64s(n)
            + 3 * u32s(n);
        let pair_slots = u32s(m.pair_ij.len())
            + f64s(m.pair_history.len())
            + f64s(history::LEN * pairs)
            + u32s(pair_ij::LEN * pairs)
            + f64s(history::LEN * pairs)
            + u32s(m.rows.len());
        let wall_slots = u32s(m.cands.len())
            + f64s(m.wall_history.len())
            + f64s(wall_output::LEN * walls)
            + u32s(cands::LEN * walls)
            + f64s(history::LEN * walls);
        let walls_and_cells = f64s(m.table.len())
            + f64s(m.params.len())
            + f64s(m.elements.len())
            + f64s(m.geoms.len())
            + f64s(m.element_track.len())
            + f64s(m.geoms_track.len())
            + u32s(m.moving_rows() + self.geometries)
            + u32s(m.forced.len())
            + u32s(layout::ctrl::LEN + worlds)
            + u32s(self.buckets)
            + u32s(self.buckets * cap.bucket)
            + f64s(layout::geometry_loads::LEN * self.geometries.max(1));
        let extensions =
            m.bonds.as_ref().map_or(0, |b| b.bytes()) + m.bodies.as_ref().map_or(0, |b| b.bytes());
        (particles + pair_slots + wall_slots + walls_and_cells + extensions) as u64 + SMALL_BUFFERS
    }
}

/// The device buffers of one try, named as the kernels bind them.
pub(super) struct Buffers {
    pub(super) state: wgpu::Buffer,
    pub(super) loads: wgpu::Buffer,
    pub(super) props: wgpu::Buffer,
    pub(super) body: wgpu::Buffer,
    pub(super) ints: wgpu::Buffer,
    pub(super) built: wgpu::Buffer,
    pub(super) params: wgpu::Buffer,
    /// `counts` for launches over the particles and the buckets.
    pub(super) counts_n: wgpu::Buffer,
    pub(super) counts_buckets: wgpu::Buffer,
    pub(super) moved: wgpu::Buffer,
    pub(super) outside: wgpu::Buffer,
    pub(super) status: wgpu::Buffer,
    pub(super) pair_ij: wgpu::Buffer,
    /// The pair histories in two halves, by the parity of the step (`history_halves.wgsl`).
    pub(super) history_even: Split,
    pub(super) history_odd: Split,
    pub(super) new_ij: wgpu::Buffer,
    pub(super) new_pair_history: Split,
    pub(super) rows: wgpu::Buffer,
    pub(super) cands: wgpu::Buffer,
    pub(super) wall_history: Split,
    pub(super) wall_output: Split,
    pub(super) new_cands: wgpu::Buffer,
    pub(super) new_wall_history: Split,
    pub(super) table: wgpu::Buffer,
    pub(super) elements: wgpu::Buffer,
    pub(super) geoms: wgpu::Buffer,
    pub(super) element_track: wgpu::Buffer,
    pub(super) geoms_track: wgpu::Buffer,
    /// The element of each moving row, and `counts` for the poses' launch.
    pub(super) pose_table: wgpu::Buffer,
    pub(super) counts_poses: wgpu::Buffer,
    pub(super) forced: wgpu::Buffer,
    pub(super) ctrl: wgpu::Buffer,
    pub(super) dims: wgpu::Buffer,
    pub(super) search: wgpu::Buffer,
    pub(super) bucket_count: wgpu::Buffer,
    pub(super) bucket_items: wgpu::Buffer,
    pub(super) reverse_count: wgpu::Buffer,
    pub(super) geometry_loads: wgpu::Buffer,
    pub(super) bonds: Option<BondBuffers>,
    pub(super) bodies: Option<BodyBuffers>,
}

impl Buffers {
    /// The parts each [`Split`] list is bound in (all alike): 1, or `kernels::PARTS` where one
    /// passes a binding.
    pub(super) fn parts(&self) -> usize {
        self.history_even.0.len()
    }

    /// The buffers a segment's end reads (its read-back and the end's `check` and
    /// `geometry_loads`) and the steps change: what a snapshot at a step of parity `half` copies
    /// ([`Snapshots`]). Of the pair histories only that half: a world still stepping there has
    /// its histories in it, and a world that stopped before writes neither half again.
    pub(super) fn kept(&self, half: usize) -> Vec<&wgpu::Buffer> {
        let mut kept = vec![
            &self.ctrl,
            &self.state,
            &self.loads,
            &self.pair_ij,
            &self.rows,
            &self.cands,
            // What `check` reads at the end: the drift since the last build, leaving the domain,
            // a wall row's status.
            &self.moved,
            &self.outside,
            &self.status,
        ];
        kept.extend([&self.history_even, &self.history_odd][half].parts());
        kept.extend(self.wall_history.parts().chain(self.wall_output.parts()));
        // Bond ends' `BE_INTACT` is not kept: nothing at the end reads it, and the next try
        // uploads it anew.
        if let Some(b) = &self.bonds {
            kept.extend([&b.state, &b.output, &b.broke]);
        }
        if let Some(b) = &self.bodies {
            kept.push(&b.rows);
        }
        kept
    }

    /// The bytes of every buffer (what [`Sizes::bytes`] must not fall short of).
    pub(super) fn bytes(&self) -> u64 {
        self.all().iter().map(|b| b.size()).sum()
    }

    /// Every buffer.
    pub(super) fn all(&self) -> Vec<&wgpu::Buffer> {
        let mut all = vec![
            &self.state,
            &self.loads,
            &self.props,
            &self.body,
            &self.ints,
            &self.built,
            &self.params,
            &self.counts_n,
            &self.counts_buckets,
            &self.moved,
            &self.outside,
            &self.status,
            &self.pair_ij,
            &self.new_ij,
            &self.rows,
            &self.cands,
            &self.new_cands,
            &self.table,
            &self.elements,
            &self.geoms,
            &self.element_track,
            &self.geoms_track,
            &self.pose_table,
            &self.counts_poses,
            &self.forced,
            &self.ctrl,
            &self.dims,
            &self.search,
            &self.bucket_count,
            &self.bucket_items,
            &self.reverse_count,
            &self.geometry_loads,
        ];
        for split in [
            &self.history_even,
            &self.history_odd,
            &self.new_pair_history,
            &self.wall_history,
            &self.wall_output,
            &self.new_wall_history,
        ] {
            all.extend(split.parts());
        }
        if let Some(b) = &self.bonds {
            all.extend(b.all());
        }
        if let Some(b) = &self.bodies {
            all.extend(b.all());
        }
        all
    }

    pub(super) fn new(
        c: &GpuContext,
        m: &Merged,
        worlds: usize,
        s: &Sizes,
        cap: Capacity,
        parts: usize,
    ) -> Buffers {
        let (n, pairs, walls) = (s.n, s.pairs, s.walls);
        let counts = |threads: usize| {
            let counts = Counts {
                particles: n,
                pairs,
                reverse: pairs,
                walls,
                bonds: 0,
                bodies: 0,
            };
            c.storage(&counts.words(threads as u32))
        };
        // Tracks only where geometries move (a binding cannot be empty).
        let track = |v: &[f64]| {
            let v: &[f64] = if m.moving.is_empty() { &[0.0] } else { v };
            c.storage(v)
        };
        // The lists are built before the first step; no world has failed.
        let mut words = vec![0u32; layout::ctrl::LEN];
        words[layout::ctrl::REBUILD] = 1;
        words[layout::ctrl::WORLDS] = worlds as u32;
        words.extend(std::iter::repeat_n(EMPTY, worlds));
        let mut dims = [0u32; layout::dims::LEN];
        dims[layout::dims::PARTICLES] = n as u32;
        dims[layout::dims::PAIR_CAPACITY] = cap.pair as u32;
        dims[layout::dims::WALL_CAPACITY] = cap.wall as u32;
        dims[layout::dims::BUCKETS] = s.buckets as u32;
        dims[layout::dims::BUCKET_CAPACITY] = cap.bucket as u32;
        dims[layout::dims::GEOMETRIES] = s.geometries as u32;
        dims[layout::dims::ELEMENTS] = s.elements as u32;
        dims[layout::dims::MOVING_ELEMENTS] = m.moving_rows() as u32;
        let body = layout::ints::BODY * n..(layout::ints::BODY + 1) * n;
        // The buffers that start as zeros are cleared on the device (one submission, after the
        // others' writes and before any kernel).
        let mut zero = c.device.create_command_encoder(&Default::default());
        let buffers = Buffers {
            state: c.storage(&m.state),
            loads: c.storage(&m.loads),
            props: c.storage(&m.props),
            body: c.storage(&m.ints[body]),
            ints: c.storage(&m.ints),
            built: c.zeros::<f64>(&mut zero, 3 * n),
            params: c.storage(&m.params),
            counts_n: counts(n),
            counts_buckets: counts(s.buckets),
            moved: c.zeros::<f64>(&mut zero, n),
            outside: c.zeros::<u32>(&mut zero, n),
            status: c.zeros::<u32>(&mut zero, n),
            pair_ij: c.storage(&m.pair_ij),
            // The host's histories are those before step 0.
            history_even: Split::with(c, &m.pair_history, parts),
            history_odd: Split::zeros(c, &mut zero, layout::history::LEN * pairs, parts),
            new_ij: c.storage(&vec![EMPTY; layout::pair_ij::LEN * pairs]),
            new_pair_history: Split::zeros(c, &mut zero, layout::history::LEN * pairs, parts),
            rows: c.storage(&m.rows),
            cands: c.storage(&m.cands),
            wall_history: Split::with(c, &m.wall_history, parts),
            wall_output: Split::zeros(c, &mut zero, layout::wall_output::LEN * walls, parts),
            new_cands: c.storage(&vec![EMPTY; layout::cands::LEN * walls]),
            new_wall_history: Split::zeros(c, &mut zero, layout::history::LEN * walls, parts),
            table: c.storage(&m.table),
            elements: c.storage(&m.elements),
            geoms: c.storage(&m.geoms),
            element_track: track(&m.element_track),
            geoms_track: track(&m.geoms_track),
            pose_table: c.storage(&m.pose_table()),
            counts_poses: counts(m.moving_rows() + s.geometries),
            forced: c.storage(&m.forced),
            ctrl: c.storage(&words),
            dims: c.storage(&dims),
            search: c.storage(&m.search),
            bucket_count: c.zeros::<u32>(&mut zero, s.buckets),
            bucket_items: c.zeros::<u32>(&mut zero, s.buckets * cap.bucket),
            reverse_count: c.zeros::<u32>(&mut zero, n),
            geometry_loads: c
                .zeros::<f64>(&mut zero, layout::geometry_loads::LEN * s.geometries.max(1)),
            bonds: m.bonds.as_ref().map(|mb| BondBuffers::new(c, mb, n)),
            bodies: m.bodies.as_ref().map(|mb| BodyBuffers::new(c, mb, n)),
        };
        c.queue.submit([zero.finish()]);
        buffers
    }
}

/// A list of f64 bound in parts (1, or `kernels::PARTS` where a list of the try passes one binding) of
/// at most [`GpuContext::part_numbers`] numbers each, in order (`kernels::split_lists`): the pair
/// and wall histories and the wall outputs, the largest lists, so that a scene's lists may be
/// larger than one binding. The parts past the list's end hold one number (a binding cannot be
/// empty). The caller checks that the list fits the parts.
pub(super) struct Split(Vec<wgpu::Buffer>);

impl Split {
    /// The parts a list of `len` numbers takes.
    pub(super) fn parts_for(c: &GpuContext, len: usize) -> usize {
        len.div_ceil(c.part_numbers).max(1)
    }

    /// `data`, in `parts` parts.
    fn with(c: &GpuContext, data: &[f64], parts: usize) -> Split {
        let made = data.chunks(c.part_numbers).map(|d| c.storage(d)).collect();
        Split::padded(c, made, parts)
    }

    /// `len` zeros in `parts` parts, cleared on the device by `encoder` ([`GpuContext::zeros`]).
    fn zeros(
        c: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        len: usize,
        parts: usize,
    ) -> Split {
        let part = c.part_numbers;
        let made = (0..len.div_ceil(part))
            .map(|p| c.zeros::<f64>(encoder, part.min(len - p * part)))
            .collect();
        Split::padded(c, made, parts)
    }

    fn padded(c: &GpuContext, mut made: Vec<wgpu::Buffer>, parts: usize) -> Split {
        debug_assert!(
            made.len() <= parts,
            "a list in {} parts of {parts}",
            made.len()
        );
        while made.len() < parts {
            made.push(c.storage(&[0.0f64]));
        }
        Split(made)
    }

    /// The parts, in order, as the kernels bind them.
    pub(super) fn parts(&self) -> impl Iterator<Item = &wgpu::Buffer> {
        self.0.iter()
    }
}

/// A try's buffers, made in error scopes: out of memory in a buffer's creation makes it invalid,
/// and the write of its data then a validation error, both caught here, neither the device's
/// failure. The last segment's buffers are reused where they fit beside this one's `needed`
/// bytes (`pool`); where the driver still runs out of memory, they are freed and the buffers
/// made once more before the batch is packed smaller.
pub(super) fn make_buffers(
    c: &GpuContext,
    m: &Merged,
    worlds: usize,
    sizes: &Sizes,
    cap: Capacity,
    needed: u64,
    parts: usize,
) -> Result<Buffers, Retry> {
    c.pool.make_room(needed, c.memory);
    loop {
        let memory = c.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = c.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let b = Buffers::new(c, m, worlds, sizes, cap, parts);
        let invalid = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(memory.pop());
        match (invalid, out_of_memory) {
            (Some(e), None) => {
                return Err(Retry::Failed(format!(
                    "the GPU {} refused a segment's buffers: {}",
                    c.adapter,
                    crate::failure::one_line(&e.to_string())
                )))
            }
            (None, None) => return Ok(b),
            (_, Some(_)) if c.pool.clear() => {
                // The queue holds the buffers written (and their staging) until a submission is
                // done: an empty one, waited for, lets their memory go before the next attempt.
                drop(b);
                c.queue.submit([]);
                let _ = c.device.poll(wgpu::PollType::Wait {
                    submission_index: None,
                    timeout: None,
                });
            }
            (_, Some(e)) => {
                // Out of memory at the driver's count: half as much may fit.
                eprintln!(
                    "warning: the GPU {} ran out of memory for {} world(s) needing {:.3} GB: {}",
                    c.adapter,
                    worlds,
                    needed as f64 * 1e-9,
                    crate::failure::one_line(&e.to_string())
                );
                return Err(Retry::Memory {
                    needed,
                    room: needed / 2,
                });
            }
        }
    }
}
