//! One try of a batch of worlds on the device at given capacities: the launch list of a step
//! (over the buffers of `buffers`), the steps in chunks of [`CHUNK`], and the read-back of every
//! world's end.

use dem::sim::SegmentEnd;

use super::buffers::{make_buffers, Buffers, Sizes, Split};
use super::snapshot::{self, Snapshots};
use super::world::{Ended, Merged, World};
use super::PendingRead;
use super::{
    check_overflow, chunk_steps, encode, encode_timed, Capacity, Launch, Retry, CHUNK, EMPTY,
};
use crate::kernels::PARTS;
use crate::layout;
use crate::{GpuContext, GpuStages};

/// The launches of one try: a step runs `begin`, the poses, the clumps' first half,
/// `integrate`, `check`, the rebuild, the forces, the bonds and the clumps' last half in that
/// order (those a run has); the end runs `begin`, `check` and the geometry loads.
struct Launches<'a> {
    begin: Launch<'a>,
    integrate: Launch<'a>,
    check: Launch<'a>,
    rebuild: [Launch<'a>; 6],
    forces: [Launch<'a>; 3],
    /// The bond kernel and the bond sums, after the forces, when a world has bonds.
    bonds: Option<[Launch<'a>; 2]>,
    /// The clumps' first half (before `integrate`) and last (after the forces and bonds).
    bodies: Option<[Launch<'a>; 2]>,
    /// The step's geometry poses, after `begin`, where geometries move.
    poses: Option<Launch<'a>>,
    geometry_loads: Launch<'a>,
}

/// A launch of `pipeline` over `threads` threads with `buffers` bound in order.
pub(super) fn launch<'a>(
    c: &GpuContext,
    pipeline: &'a wgpu::ComputePipeline,
    buffers: &[&wgpu::Buffer],
    threads: usize,
) -> Launch<'a> {
    Launch {
        name: c.kernel_name(pipeline),
        pipeline,
        group: c.bind(pipeline, buffers),
        threads: threads as u32,
        indirect: None,
    }
}

/// A launch of `pipeline` with `own` bound in order, then each of `split`'s parts
/// (`kernels::split_lists`), as many as `pipeline` binds (`ResidentKernels::pick`).
fn launch_split<'a>(
    c: &GpuContext,
    pipeline: &'a wgpu::ComputePipeline,
    own: &[&wgpu::Buffer],
    split: &[&Split],
    threads: usize,
) -> Launch<'a> {
    let parts = split.iter().flat_map(|s| s.parts());
    let buffers: Vec<&wgpu::Buffer> = own.iter().copied().chain(parts).collect();
    launch(c, pipeline, &buffers, threads)
}

impl<'a> Launches<'a> {
    fn new(c: &'a GpuContext, b: &Buffers, s: &Sizes, m: &Merged) -> Launches<'a> {
        let k = &c.resident;
        let n = s.n;
        let bonds = b.bonds.as_ref().zip(m.bonds.as_ref()).map(|(bb, mb)| {
            bb.launches(
                c,
                &b.state,
                &b.loads,
                &b.props,
                &b.params,
                &b.counts_n,
                &b.ctrl,
                &b.body,
                mb.count,
                n,
            )
        });
        let bodies = b
            .bodies
            .as_ref()
            .zip(m.bodies.as_ref())
            .map(|(bb, mb)| bb.launches(c, &b.state, &b.props, &b.params, &b.loads, mb.count));
        let poses = (!m.moving.is_empty()).then(|| {
            launch(
                c,
                &k.poses,
                &[
                    &b.ctrl,
                    &b.dims,
                    &b.counts_poses,
                    &b.pose_table,
                    &b.element_track,
                    &b.geoms_track,
                    &b.elements,
                    &b.geoms,
                ],
                m.moving_rows() + s.geometries,
            )
        });
        Launches {
            bonds,
            bodies,
            poses,
            begin: launch(c, &k.begin, &[&b.ctrl, &b.forced, &b.params], 0),
            integrate: launch(
                c,
                &c.integrate,
                &[
                    &b.state,
                    &b.loads,
                    &b.props,
                    &b.body,
                    &b.built,
                    &b.params,
                    &b.counts_n,
                    &b.moved,
                    &b.outside,
                ],
                n,
            ),
            check: launch(
                c,
                &k.check,
                &[
                    &b.state,
                    &b.counts_n,
                    &b.moved,
                    &b.outside,
                    &b.status,
                    &b.ctrl,
                    &b.search,
                    &b.props,
                    &b.params,
                ],
                n,
            ),
            rebuild: Self::rebuild(c, b, s),
            forces: Self::forces(c, b, s),
            // Once at the end: a world that stopped earlier kept its rows and wall output.
            geometry_loads: launch_split(
                c,
                k.pick(b, &k.geometry_loads, |v| &v.geometry_loads),
                &[&b.dims, &b.rows, &b.cands, &b.geometry_loads, &b.params],
                &[&b.wall_output],
                // One workgroup a geometry.
                crate::WORKGROUP as usize * s.geometries.max(1),
            ),
        }
    }

    /// The list rebuild (each kernel returns at once in a step without one).
    fn rebuild(c: &'a GpuContext, b: &Buffers, s: &Sizes) -> [Launch<'a>; 6] {
        let k = &c.resident;
        let n = s.n;
        [
            launch(
                c,
                &k.clear,
                &[
                    &b.counts_buckets,
                    &b.ctrl,
                    &b.bucket_count,
                    &b.reverse_count,
                    &b.dims,
                ],
                s.buckets,
            ),
            launch(
                c,
                &k.bin,
                &[
                    &b.state,
                    &b.counts_n,
                    &b.ctrl,
                    &b.bucket_count,
                    &b.bucket_items,
                    &b.dims,
                    &b.search,
                    &b.props,
                    &b.params,
                ],
                n,
            ),
            launch_split(
                c,
                k.pick(b, &k.build_pairs, |v| &v.build_pairs),
                &[
                    &b.state,
                    &b.props,
                    &b.counts_n,
                    &b.ctrl,
                    &b.bucket_count,
                    &b.bucket_items,
                    &b.dims,
                    &b.search,
                    &b.pair_ij,
                    &b.new_ij,
                    &b.rows,
                    &b.reverse_count,
                    &b.built,
                    &b.params,
                ],
                &[&b.history_even, &b.history_odd, &b.new_pair_history],
                n,
            ),
            launch_split(
                c,
                k.pick(b, &k.build_walls, |v| &v.build_walls),
                &[
                    &b.state,
                    &b.counts_n,
                    &b.props,
                    &b.ctrl,
                    &b.dims,
                    &b.search,
                    &b.elements,
                    &b.geoms,
                    &b.cands,
                    &b.new_cands,
                    &b.rows,
                    &b.params,
                ],
                &[&b.wall_history, &b.new_wall_history],
                n,
            ),
            launch(
                c,
                &k.sort_reverse,
                &[&b.counts_n, &b.ctrl, &b.rows, &b.reverse_count, &b.dims],
                n,
            ),
            launch_split(
                c,
                k.pick(b, &k.commit, |v| &v.commit),
                &[
                    &b.counts_n,
                    &b.ctrl,
                    &b.dims,
                    &b.pair_ij,
                    &b.new_ij,
                    &b.cands,
                    &b.new_cands,
                    &b.props,
                    &b.params,
                ],
                &[
                    &b.history_even,
                    &b.history_odd,
                    &b.new_pair_history,
                    &b.wall_history,
                    &b.new_wall_history,
                ],
                n,
            ),
        ]
    }

    /// The wall contacts (the check path's kernel), each particle's pair contacts and sums
    /// (`particle_forces`: no per-pair output), then the second half kick.
    fn forces(c: &'a GpuContext, b: &Buffers, s: &Sizes) -> [Launch<'a>; 3] {
        [
            launch_split(
                c,
                c.resident.pick(b, &c.wall_forces, |v| &v.wall_forces),
                &[
                    &b.state,
                    &b.props,
                    &b.ints,
                    &b.elements,
                    &b.geoms,
                    &b.cands,
                    &b.rows,
                    &b.table,
                    &b.params,
                    &b.counts_n,
                    &b.status,
                ],
                &[&b.wall_history, &b.wall_output],
                s.n,
            ),
            launch_split(
                c,
                c.resident
                    .pick(b, &c.resident.particle_forces, |v| &v.particle_forces),
                &[
                    &b.state,
                    &b.loads,
                    &b.props,
                    &b.ints,
                    &b.pair_ij,
                    &b.rows,
                    &b.table,
                    &b.params,
                    &b.counts_n,
                    &b.ctrl,
                ],
                &[&b.history_even, &b.history_odd, &b.wall_output],
                s.n,
            ),
            launch(
                c,
                &c.resident.kick,
                &[
                    &b.state,
                    &b.loads,
                    &b.props,
                    &b.body,
                    &b.params,
                    &b.counts_n,
                ],
                s.n,
            ),
        ]
    }
}

/// The parts a try binds its split lists in when the longest takes `parts`: one where each fits
/// one binding (the kernels' plain variants), else all (their variants in parts).
fn bound_in(parts: usize) -> usize {
    if parts == 1 {
        1
    } else {
        PARTS
    }
}

/// A split list's parts read back, as one (without a copy where it is in one part).
fn join(mut parts: Vec<Vec<u8>>) -> Vec<u8> {
    match parts.len() {
        1 => parts.pop().unwrap_or_default(),
        _ => parts.concat(),
    }
}

/// `bytes` in GB, MB below one GB, or bytes below one MB.
fn size(bytes: u64) -> String {
    match bytes {
        1_000_000_000.. => format!("{:.2} GB", bytes as f64 * 1e-9),
        1_000_000.. => format!("{:.1} MB", bytes as f64 * 1e-6),
        _ => format!("{bytes} bytes"),
    }
}

impl GpuStages {
    pub(super) fn try_run(
        &self,
        worlds: &[World],
        cap: Capacity,
    ) -> Result<(Vec<SegmentEnd>, Option<u32>), Retry> {
        let c = &*self.ctx;
        let mut phases = crate::profile::HostPhases::start();
        let sizes = Sizes::of(worlds, cap);
        let m = Merged::new(worlds, cap).map_err(Retry::Overflow)?;
        phases.mark("merge");
        let largest = sizes.largest(&m, cap);
        // A pair slot's row index (`H_LEN * q`, `IJ_LEN * q`) must fit u32.
        let row = layout::history::LEN.max(layout::pair_ij::LEN);
        if !c.fits(largest.1) || sizes.pairs >= u32::MAX as usize / row {
            return Err(Retry::Decline(format!(
                "its {} ({}) do not fit one binding of {} ({})",
                largest.0,
                size(largest.1 as u64),
                c.adapter,
                size(c.max_binding)
            )));
        }
        // The largest lists are bound in parts (`Split`) where one passes a binding.
        let mut parts = 1;
        for (what, numbers) in sizes.split_lists() {
            let needs = Split::parts_for(c, numbers);
            if needs > PARTS {
                return Err(Retry::Decline(format!(
                    "its {what} ({}) do not fit {PARTS} bindings of {} ({} each)",
                    size(8 * numbers as u64),
                    c.adapter,
                    size(8 * c.part_numbers as u64)
                )));
            }
            if needs > 1 && c.resident.in_parts.is_none() {
                return Err(Retry::Decline(format!(
                    "its {what} ({}) pass one binding of {} ({}), and the device allows a kernel too few storage bindings for the kernels that bind them in parts",
                    size(8 * numbers as u64),
                    c.adapter,
                    size(8 * c.part_numbers as u64)
                )));
            }
            parts = parts.max(needs);
        }
        // A batch that needs more memory than there is room for is packed into smaller ones
        // (`batch::pack`); a world alone tries, and the driver says whether it fits.
        let needed = sizes.bytes(&m, cap, worlds.len());
        if worlds.len() > 1 && needed > c.memory {
            return Err(Retry::Memory {
                needed,
                room: c.memory,
            });
        }
        // Out of memory in a buffer's creation makes it invalid, and the write of its data then
        // a validation error: both caught here, neither the device's failure.
        let b = make_buffers(c, &m, worlds.len(), &sizes, cap, needed, bound_in(parts))?;
        phases.mark("buffers");
        // The count must bound what was made (for the packing); a miscount is a bug, said as a
        // decline so that it shows where it happens.
        if b.bytes() > needed {
            return Err(Retry::Decline(format!(
                "its buffers took {} bytes, over the {needed} counted for them",
                b.bytes()
            )));
        }
        crate::batch::note_bytes(worlds.len(), b.bytes());
        c.parts_used
            .fetch_max(parts, std::sync::atomic::Ordering::Relaxed);
        let mut l = Launches::new(c, &b, &sizes, &m);
        phases.mark("bind groups");
        // The rebuild kernels start their threads only in a step with a rebuild (`plan`): their
        // workgroups as indirect arguments, all of them at first (the lists are built before the
        // first step).
        let full: Vec<u32> = l
            .rebuild
            .iter()
            .flat_map(|r| {
                let (x, y) = crate::groups(r.threads);
                [x, y, 1]
            })
            .collect();
        let args = c.storage_with(bytemuck::cast_slice(&full), wgpu::BufferUsages::INDIRECT);
        let full_buffer = c.storage(&full);
        for (k, r) in l.rebuild.iter_mut().enumerate() {
            r.indirect = Some((args.clone(), 12 * k as u64));
        }
        let plan = launch(
            c,
            &c.resident.plan,
            &[&b.ctrl, &full_buffer, &args],
            full.len(),
        );
        // One step's launches, in order (the same every step).
        let step: Vec<&Launch> = [&l.begin]
            .into_iter()
            .chain(l.poses.iter())
            .chain(l.bodies.iter().map(|b| &b[0]))
            .chain([&l.integrate, &l.check, &plan])
            .chain(l.rebuild.iter())
            .chain(l.forces.iter())
            .chain(l.bonds.iter().flatten())
            .chain(l.bodies.iter().map(|b| &b[1]))
            .collect();

        // The lists for the state at the start (their histories from the host's lists), submitted
        // without a wait: an overflow in them stays in the control words, so the first chunk's
        // read (or the end's) runs the segment again with more room, as an overflow in the
        // first chunk does.
        let mut encoder = c.device.create_command_encoder(&Default::default());
        encode(&mut encoder, &l.rebuild.iter().collect::<Vec<_>>());
        c.queue.submit([encoder.finish()]);
        phases.mark("submit");
        let mut spare = vec![args.clone(), full_buffer.clone()];
        let stopped = self.run_chunks(worlds, &sizes, &b, &step, needed, &mut spare)?;
        phases.mark("steps");
        let end = self.read_end(worlds, &m, &b, &l, stopped, &mut phases);
        phases.mark("split");
        if end.is_ok() {
            // Every submission is done: the next segment may write over these buffers.
            spare.extend(b.all().into_iter().cloned());
            c.pool.keep(spare);
        }
        phases.record();
        end
    }

    /// The end of a try whose steps ran (`stopped`: the overflow that ended them early, and
    /// where): the last step's check and the geometry loads, then the read-back of what each
    /// world's end holds.
    fn read_end(
        &self,
        worlds: &[World],
        m: &Merged,
        b: &Buffers,
        l: &Launches,
        stopped: Option<(u32, usize)>,
        phases: &mut crate::profile::HostPhases,
    ) -> Result<(Vec<SegmentEnd>, Option<u32>), Retry> {
        let c = &*self.ctx;
        let mut encoder = c.device.create_command_encoder(&Default::default());
        // The last step's kick, checked as every step's are: the worlds whose steps ran to the
        // end are still stepping, so `begin` marks them for the check alone.
        encode(&mut encoder, &[&l.begin, &l.check, &l.geometry_loads]);
        let mut buffers = vec![
            &b.ctrl,
            &b.state,
            &b.loads,
            &b.pair_ij,
            &b.rows,
            &b.cands,
            &b.geometry_loads,
        ];
        if let Some(bb) = &b.bonds {
            buffers.extend([&bb.state, &bb.output, &bb.broke]);
        }
        if let Some(bb) = &b.bodies {
            buffers.push(&bb.rows);
        }
        let split = [&b.history_even, &b.history_odd, &b.wall_history];
        buffers.extend(split.iter().flat_map(|s| s.parts()));
        let mut out = c.read_back(encoder, &buffers).map_err(Retry::Failed)?;
        phases.mark("read back");
        // Each split list's parts as one (the one-number parts past its end come after it), in
        // its place among the others.
        let wall_history = join(out.split_off(out.len() - b.parts()));
        let odd = join(out.split_off(out.len() - b.parts()));
        let even = join(out.split_off(out.len() - b.parts()));
        out.insert(4, even);
        out.insert(5, odd);
        out.insert(8, wall_history);
        check_overflow(&out[0])?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
        let failed: Vec<Option<u64>> = words
            [layout::ctrl::FAILED..layout::ctrl::FAILED + worlds.len()]
            .iter()
            .map(|&f| (f != EMPTY).then_some(f as u64))
            .collect();
        // The first rebuild, before the first step, is not the simulation's.
        let rebuilds = words[layout::ctrl::REBUILDS].saturating_sub(1) as u64;
        let mut at = 10;
        let bonds = match &m.bonds {
            Some(mb) => {
                at += 3;
                mb.split(worlds, [&out[10], &out[11], &out[12]])
            }
            None => worlds.iter().map(|_| None).collect(),
        };
        let bodies = match &m.bodies {
            Some(mb) => mb.split(worlds, &out[at]),
            None => worlds.iter().map(|_| None).collect(),
        };
        let ended = Ended {
            rebuilds,
            failed: &failed,
            stop: stopped.map(|(_, step)| step as u64),
        };
        let ends = m.split(worlds, &out, ended, bonds, bodies);
        Ok((ends, stopped.map(|(code, _)| code)))
    }

    /// The steps of a try in chunks (see the module notes), after the lists are built: Ok(None)
    /// when every world ran its steps or failed, Ok(Some((overflow code, step))) when an
    /// overflow ended the run early at `step`, whose state is back in the buffers.
    fn run_chunks(
        &self,
        worlds: &[World],
        sizes: &Sizes,
        b: &Buffers,
        step: &[&Launch],
        needed: u64,
        spare: &mut Vec<wgpu::Buffer>,
    ) -> Result<Option<(u32, usize)>, Retry> {
        let c = &*self.ctx;
        // A world is over once its steps are run or it failed; the run stops when all are.
        let over = |words: &[u32], done: usize| {
            worlds.iter().enumerate().all(|(w, world)| {
                done >= world.steps as usize || words[layout::ctrl::FAILED + w] != EMPTY
            })
        };
        let mut done = 0usize;
        // A profiled chunk holds at most [`CHUNK`] steps (its stamps' query set is sized so).
        let timer = Timer::new(c, step.len() * CHUNK as usize);
        let most = match &timer {
            Some(_) => CHUNK.min(chunk_steps()) as usize,
            None => chunk_steps() as usize,
        };
        // Tight lists (a test of the overflow paths) come with short chunks, so that an overflow
        // after the first chunk, with a copy to go back to, is likely.
        let most = if self.tight { most.min(8) } else { most };
        // Copies of the state at each chunk's start where the segment is long enough to gain
        // by them and there is room (`snapshot`): an overflow then ends the segment at its
        // chunk's start. Where the driver has no memory for them, none are taken.
        // (Both halves' lists of buffers have the same sizes.)
        let kept = [b.kept(0), b.kept(1)];
        let mut snaps = None;
        let copies = Snapshots::bytes(&kept[0]);
        if sizes.steps > snapshot::FEWEST_CHUNKS * most && needed + copies <= c.memory {
            // What the pool still holds counts too (its copies from the last segment are used
            // first).
            c.pool.make_room(needed + copies, c.memory);
            let scope = c.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let made = Snapshots::new(c, &kept[0]);
            if pollster::block_on(scope.pop()).is_none() {
                snaps = Some(made);
            }
        }
        // The chunk in flight: its read, the steps encoded through it, the step it started at
        // and its set of copies. Without the profile the next chunk is encoded and submitted
        // before the one in flight is waited for, so that the host's encoding overlaps the
        // device's work (a chunk run after every world is over steps none of them).
        let mut in_flight: Option<(PendingRead, usize, usize, usize)> = None;
        let mut chunks = 0usize;
        // Where an overflow ended the segment early: its code and the step the state went back to.
        let mut stopped: Option<(u32, usize)> = None;
        // The overflow word of a chunk's read: Ok(None) when clean, Ok(Some(code)) when the
        // segment can end at the chunk's start instead (a copy was taken there, after step 0).
        let copies = snaps.is_some();
        let overflowed = |words: &[u8], start: usize| -> Result<Option<u32>, Retry> {
            match check_overflow(words) {
                Ok(()) => Ok(None),
                Err(Retry::Overflow(code)) if copies && start > 0 => Ok(Some(code)),
                Err(e) => Err(e),
            }
        };
        loop {
            if done >= sizes.steps {
                // Every step is encoded: the last chunk's words say only whether it overflowed.
                if let Some((p, _, start, set)) = in_flight.take() {
                    let out = c.wait_read(p).map_err(Retry::Failed)?;
                    if let Some(code) = overflowed(&out[0], start)? {
                        stopped = Some((code, set));
                    }
                }
                break;
            }
            let chunk = (sizes.steps - done).min(most);
            let mut encoder = c.device.create_command_encoder(&Default::default());
            let (start, set) = (done, chunks % 2);
            // (A copy at step 0 would never be used: the segment then runs again from its start.)
            if let Some(sn) = snaps.as_mut().filter(|_| start > 0) {
                sn.take(&mut encoder, &kept[start % 2], set, start);
            }
            chunks += 1;
            match &timer {
                Some(t) => {
                    for s in 0..chunk {
                        let first = (s * step.len()) as u32;
                        encode_timed(&mut encoder, step, &t.stamps, first);
                    }
                }
                // The chunk's steps in one pass (the poses are a launch of the step's own).
                None => {
                    let launches: Vec<&Launch> =
                        (0..chunk).flat_map(|_| step.iter().copied()).collect();
                    encode(&mut encoder, &launches);
                }
            }
            done += chunk;
            let (out, at, start, set) = match &timer {
                Some(t) => {
                    // One chunk at a time: the stamps' query set is reused.
                    let queries = (2 * chunk * step.len()) as u32;
                    encoder.resolve_query_set(&t.stamps, 0..queries, &t.resolved, 0);
                    let out = c
                        .read_back(encoder, &[&b.ctrl, &t.resolved])
                        .map_err(Retry::Failed)?;
                    let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&out[1]);
                    let names: Vec<&'static str> = (0..chunk)
                        .flat_map(|_| step.iter().map(|l| l.name))
                        .collect();
                    crate::profile::add(&names, &stamps, c.queue.get_timestamp_period());
                    (out, done, start, set)
                }
                None => {
                    let next = (c.submit_read(encoder, &[&b.ctrl]), done, start, set);
                    let Some((p, at, start, set)) = in_flight.replace(next) else {
                        continue;
                    };
                    (c.wait_read(p).map_err(Retry::Failed)?, at, start, set)
                }
            };
            if let Some(code) = overflowed(&out[0], start)? {
                // The chunk after it, if submitted, runs on; the copies go back after it.
                if let Some((p, ..)) = in_flight.take() {
                    c.wait_read(p).map_err(Retry::Failed)?;
                }
                stopped = Some((code, set));
                break;
            }
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
            if over(&words, at) {
                break;
            }
        }
        // An overflow ended the segment early: the state of its chunk's start goes back (after
        // every chunk submitted, in the queue's order).
        let stopped = match (stopped, &snaps) {
            (Some((code, set)), Some(sn)) => {
                let mut encoder = c.device.create_command_encoder(&Default::default());
                let step = sn.restore(&mut encoder, &kept[sn.taken_at(set) % 2], set);
                c.queue.submit([encoder.finish()]);
                Some((code, step))
            }
            _ => None,
        };
        spare.extend(snaps.into_iter().flat_map(Snapshots::into_buffers));
        Ok(stopped)
    }
}

/// The timestamp queries of a profiled segment (`crate::profile`): None unless profiling was
/// asked for and the device has timestamp queries.
struct Timer {
    stamps: wgpu::QuerySet,
    /// Where the stamps are resolved to, for the read-back.
    resolved: wgpu::Buffer,
}

impl Timer {
    fn new(c: &GpuContext, launches: usize) -> Option<Timer> {
        if !crate::profile::asked()
            || !c.has_timestamps()
            || launches > crate::profile::MOST_LAUNCHES
        {
            return None;
        }
        let count = 2 * launches as u32;
        Some(Timer {
            stamps: c.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolved: c.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("kernel timestamps"),
                size: 8 * count as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
        })
    }
}
