//! Device-resident steps: a whole segment of steps ([`dem::sim::segment`]) with the particles,
//! lists and histories kept on the GPU.
//!
//! Each step is one run of kernels with no host round trip: `begin` (the host's forced-rebuild
//! flag for the step), `poses` where geometries move, `bodies_first` where there are clumps,
//! `integrate`, `check` (half-skin displacement, failures), the rebuild kernels (`clear`, `bin`,
//! `build_pairs`, `build_walls`, `sort_reverse`, `commit`, dispatched with the workgroups `plan`
//! writes after `check`: none without a rebuild; each also returns at once when none is due),
//! then `wall_forces` (the check path's kernel), `particle_forces` (each particle evaluates the
//! contacts of its pair row and of its reverse row itself, from the pair histories' half of the
//! step, and sums them with its walls: both particles of a pair evaluate it with the same
//! arithmetic, only its first writes the new history, into the other half, so no per-pair output
//! is written or read) and `kick` (the second half kick), and where a world has them
//! `bond_forces` and `bond_sums` (`bonds`) and `bodies_last` (`bodies`). The lists the kernels
//! read
//! have a fixed capacity per particle, so a rebuild needs no prefix sums and no host: a particle's
//! pair row holds its j > i sorted by j (its history found by a merge with the old row), its
//! reverse row the sorted slots where it is j, so every particle sums its contacts in a fixed
//! order and results are deterministic on a given device. Cells are hashed into a power-of-two
//! table of fixed-capacity buckets (no grid bounds to know). A row or bucket that overflows is
//! reported through `ctrl`. After the first chunk of a long segment it ends the segment at the
//! start of its chunk, from copies taken there ([`snapshot`]), and the host goes on in a new
//! segment; in the first chunk, or in a short segment, the segment is run again from its start
//! (the host still holds it). Either way with twice the capacity, and the same stages' later
//! segments start from the capacities that sufficed.
//!
//! The host reads a few control words every [`CHUNK`] steps (to stop a failed run early), and
//! the state once at the end of the segment. It encodes and submits each chunk before it waits for
//! the one before, so that encoding overlaps the device's work.

use std::sync::Arc;

use dem::sim::{Segment, SegmentEnd};

use crate::layout::{ctrl, overflow};
use crate::{groups, GpuContext, GpuStages};

mod bodies;
mod bonds;
mod buffers;
mod run;
mod snapshot;
pub(crate) mod world;
use world::World;

/// Steps between reads of the control words, unless `DEMCAL_GPU_CHUNK` says otherwise.
const CHUNK: u64 = 64;
/// The most steps a chunk may hold (`DEMCAL_GPU_CHUNK`): a chunk's launches are encoded in one
/// pass, and a failed world runs on to its chunk's end.
const MOST_CHUNK: u64 = 1024;

/// Steps between reads of the control words: [`CHUNK`], or `DEMCAL_GPU_CHUNK` (1 to
/// [`MOST_CHUNK`]) where it is set, so the trade between the host's waits and a failed world's
/// wasted steps can be measured on a device without a rebuild. A value out of range is refused
/// with a warning, once.
fn chunk_steps() -> u64 {
    static STEPS: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *STEPS.get_or_init(|| match std::env::var("DEMCAL_GPU_CHUNK") {
        Err(_) => CHUNK,
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(n) if (1..=MOST_CHUNK).contains(&n) => n,
            _ => {
                eprintln!(
                    "warning: DEMCAL_GPU_CHUNK={v}: expected 1 to {MOST_CHUNK} steps; using {CHUNK}"
                );
                CHUNK
            }
        },
    })
}
/// Buckets per particle in the cell hash (rounded up to a power of two).
const BUCKETS_PER_PARTICLE: usize = 2;
pub(crate) const EMPTY: u32 = u32::MAX;

/// Capacities of the fixed-size rows.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Capacity {
    pub pair: usize,
    pub wall: usize,
    pub bucket: usize,
}

impl Capacity {
    /// The capacities with the row or bucket that overflowed (`code`) twice as large.
    fn grown(self, code: u32) -> Result<Capacity, String> {
        let mut cap = self;
        match code {
            overflow::BUCKET => cap.bucket *= 2,
            // A reverse row has the pair rows' capacity.
            overflow::PAIR_ROW | overflow::REVERSE_ROW => cap.pair *= 2,
            overflow::WALL_ROW => cap.wall *= 2,
            code => return Err(format!("an unknown overflow code {code}")),
        }
        Ok(cap)
    }
}

/// Why a try stopped short.
enum Retry {
    /// A capacity was too small (an `overflow` code).
    Overflow(u32),
    /// The segment cannot run here (why: too large for a binding, a particle with too many
    /// walls).
    Decline(String),
    /// The device failed (`crate::failure`: nothing more runs on it), or refused this try's
    /// buffers (a validation error; the try is declined).
    Failed(String),
    /// The worlds together need `needed` bytes of device memory, more than the `room` there is
    /// (the context's budget, or half of `needed` where the driver ran out of memory).
    Memory { needed: u64, room: u64 },
}

/// Why worlds cannot run on the device together.
#[derive(Debug)]
pub(crate) enum Declined {
    /// They need `needed` bytes of device memory and there is room for `room`: fewer at a time
    /// may fit (`batch::pack`).
    Memory { needed: u64, room: u64 },
    /// Anything else: too large for one binding, lists that kept overflowing, a failed device.
    Why(String),
}

impl std::fmt::Display for Declined {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Declined::Memory { needed, .. } => write!(
                f,
                "the GPU ran out of memory for it ({:.3} GB)",
                *needed as f64 * 1e-9
            ),
            Declined::Why(why) => f.write_str(why),
        }
    }
}

/// The pipelines of the resident kernels.
pub(crate) struct ResidentKernels {
    begin: wgpu::ComputePipeline,
    check: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
    bin: wgpu::ComputePipeline,
    build_pairs: wgpu::ComputePipeline,
    build_walls: wgpu::ComputePipeline,
    sort_reverse: wgpu::ComputePipeline,
    commit: wgpu::ComputePipeline,
    particle_forces: wgpu::ComputePipeline,
    kick: wgpu::ComputePipeline,
    geometry_loads: wgpu::ComputePipeline,
    poses: wgpu::ComputePipeline,
    plan: wgpu::ComputePipeline,
    bond_forces: wgpu::ComputePipeline,
    bond_sums: wgpu::ComputePipeline,
    bodies_first: wgpu::ComputePipeline,
    bodies_last: wgpu::ComputePipeline,
    /// The variants that bind the largest lists in parts (`kernels::SPLIT`), for a segment
    /// whose lists pass one binding; None where the device allows a kernel fewer storage
    /// bindings than they take (such a segment is declined).
    pub(crate) in_parts: Option<InParts>,
}

/// The kernels' variants that bind the largest lists in parts (`kernels::SPLIT`).
pub(crate) struct InParts {
    wall_forces: wgpu::ComputePipeline,
    build_pairs: wgpu::ComputePipeline,
    build_walls: wgpu::ComputePipeline,
    commit: wgpu::ComputePipeline,
    particle_forces: wgpu::ComputePipeline,
    geometry_loads: wgpu::ComputePipeline,
}

impl ResidentKernels {
    /// `whole` where the try's split lists are bound in one part each, else its variant that
    /// binds them in `kernels::PARTS` (`buffers::Split`), which `in_parts` picks (a try in parts
    /// runs only where the variants were compiled: `try_run` declines it otherwise).
    fn pick<'a>(
        &'a self,
        b: &buffers::Buffers,
        whole: &'a wgpu::ComputePipeline,
        in_parts: impl Fn(&'a InParts) -> &'a wgpu::ComputePipeline,
    ) -> &'a wgpu::ComputePipeline {
        debug_assert!(
            b.parts() == 1 || self.in_parts.is_some(),
            "a try in parts without the variants in parts"
        );
        match (&self.in_parts, b.parts()) {
            (Some(v), parts) if parts > 1 => in_parts(v),
            _ => whole,
        }
    }

    /// The pipelines from `take(name)`, which hands over a compiled kernel of
    /// `kernels::kernel_sources`.
    pub(crate) fn new(
        take: &mut dyn FnMut(&str) -> wgpu::ComputePipeline,
        in_parts: bool,
    ) -> ResidentKernels {
        ResidentKernels {
            begin: take("begin"),
            check: take("check"),
            clear: take("clear"),
            bin: take("bin"),
            build_pairs: take("build_pairs"),
            build_walls: take("build_walls"),
            sort_reverse: take("sort_reverse"),
            commit: take("commit"),
            particle_forces: take("particle_forces"),
            kick: take("kick"),
            geometry_loads: take("geometry_loads"),
            poses: take("poses"),
            plan: take("plan"),
            bond_forces: take("bond_forces"),
            bond_sums: take("bond_sums"),
            bodies_first: take("bodies_first"),
            in_parts: in_parts.then(|| InParts {
                wall_forces: take("wall_forces_in_parts"),
                build_pairs: take("build_pairs_in_parts"),
                build_walls: take("build_walls_in_parts"),
                commit: take("commit_in_parts"),
                particle_forces: take("particle_forces_in_parts"),
                geometry_loads: take("geometry_loads_in_parts"),
            }),
            bodies_last: take("bodies_last"),
        }
    }
}

impl GpuContext {
    /// The kernel a pipeline of this context runs, by name (for the profile).
    pub(crate) fn kernel_name(&self, p: &wgpu::ComputePipeline) -> &'static str {
        let k = &self.resident;
        [
            (&self.integrate, "integrate"),
            (&self.pair_forces, "pair_forces"),
            (&self.wall_forces, "wall_forces"),
            (&self.particle_sums, "particle_sums"),
            (&k.begin, "begin"),
            (&k.check, "check"),
            (&k.clear, "clear"),
            (&k.bin, "bin"),
            (&k.build_pairs, "build_pairs"),
            (&k.build_walls, "build_walls"),
            (&k.sort_reverse, "sort_reverse"),
            (&k.commit, "commit"),
            (&k.particle_forces, "particle_forces"),
            (&k.kick, "kick"),
            (&k.geometry_loads, "geometry_loads"),
            (&k.poses, "poses"),
            (&k.plan, "plan"),
            (&k.bond_forces, "bond_forces"),
            (&k.bond_sums, "bond_sums"),
            (&k.bodies_first, "bodies_first"),
            (&k.bodies_last, "bodies_last"),
        ]
        .into_iter()
        .chain(k.in_parts.iter().flat_map(|v| {
            [
                (&v.wall_forces, "wall_forces_in_parts"),
                (&v.build_pairs, "build_pairs_in_parts"),
                (&v.build_walls, "build_walls_in_parts"),
                (&v.commit, "commit_in_parts"),
                (&v.particle_forces, "particle_forces_in_parts"),
                (&v.geometry_loads, "geometry_loads_in_parts"),
            ]
        }))
        .find(|(q, _)| std::ptr::eq(*q, p))
        .map_or("unknown", |(_, name)| name)
    }
}

/// Copies submitted after some work, read once that submission is done
/// ([`GpuContext::wait_read`]).
pub(crate) struct PendingRead {
    staging: Vec<wgpu::Buffer>,
    index: wgpu::SubmissionIndex,
    /// The first mapping error, set by the map callbacks during the wait.
    unmapped: Arc<std::sync::Mutex<Option<String>>>,
}

/// One kernel launch of a step: pipeline, bind group, threads.
struct Launch<'a> {
    /// The kernel's name, for the profile.
    name: &'static str,
    pipeline: &'a wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    threads: u32,
    /// Where its workgroup counts are read from at dispatch (a buffer and a byte offset), for
    /// the rebuild kernels (`plan.wgsl`); None: from `threads`.
    indirect: Option<(wgpu::Buffer, u64)>,
}

/// Launch helpers, shared with the stage-by-stage path in `lib.rs`.
impl GpuContext {
    pub(crate) fn bind(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// Copies `buffers` back (after what `encoder` holds) and waits for them. Err when the
    /// device failed: a copy that could not be mapped, or a failure recorded meanwhile (the
    /// device-lost callback and the error handler run during the wait).
    pub(crate) fn read_back(
        &self,
        encoder: wgpu::CommandEncoder,
        buffers: &[&wgpu::Buffer],
    ) -> Result<Vec<Vec<u8>>, String> {
        let pending = self.submit_read(encoder, buffers);
        self.wait_read(pending)
    }

    /// Submits what `encoder` holds with copies of `buffers` after it, to be read with
    /// [`Self::wait_read`]; meanwhile more work may be submitted.
    pub(crate) fn submit_read(
        &self,
        mut encoder: wgpu::CommandEncoder,
        buffers: &[&wgpu::Buffer],
    ) -> PendingRead {
        let staging: Vec<wgpu::Buffer> = buffers
            .iter()
            .map(|b| {
                let s = self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: None,
                    size: b.size(),
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                encoder.copy_buffer_to_buffer(b, 0, &s, 0, b.size());
                s
            })
            .collect();
        let index = self.queue.submit([encoder.finish()]);
        let unmapped = Arc::new(std::sync::Mutex::new(None::<String>));
        for s in &staging {
            let unmapped = unmapped.clone();
            s.slice(..).map_async(wgpu::MapMode::Read, move |r| {
                if let Err(e) = r {
                    unmapped
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .get_or_insert(e.to_string());
                }
            });
        }
        PendingRead {
            staging,
            index,
            unmapped,
        }
    }

    /// Waits for the submission of `pending` (not for any submitted after it) and reads its
    /// copies; Err as [`Self::read_back`].
    pub(crate) fn wait_read(&self, pending: PendingRead) -> Result<Vec<Vec<u8>>, String> {
        let PendingRead {
            staging,
            index,
            unmapped,
        } = pending;
        let waited = self.device.poll(wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: None,
        });
        let failed = |what: String| {
            let what = format!("the GPU {} failed: {what}", self.adapter);
            self.failure.record(what.clone());
            what
        };
        if let Err(e) = waited {
            return Err(failed(format!("waiting for it: {e}")));
        }
        if let Some(e) = unmapped.lock().unwrap_or_else(|e| e.into_inner()).take() {
            return Err(failed(format!("reading its results back: {e}")));
        }
        if let Some(f) = self.failure.get() {
            return Err(f);
        }
        staging
            .iter()
            .map(|s| {
                s.slice(..)
                    .get_mapped_range()
                    .map(|r| r.to_vec())
                    .map_err(|e| failed(format!("reading its results back: {e}")))
            })
            .collect()
    }
}

impl GpuStages {
    /// Runs a segment on the device (see the module notes); None when it cannot.
    pub(crate) fn segment(&self, seg: &Segment) -> Option<SegmentEnd> {
        if seg.particles.is_empty()
            || !Self::runs_pairs(&seg.inputs)
            || self.ctx.failure().is_some()
        {
            return None;
        }
        let world = World::pack(seg)?;
        match &self.member {
            Some(member) => self.run_in_batch(member, world),
            None => match self.run_worlds(std::slice::from_ref(&world)) {
                Ok(mut ends) => ends.pop(),
                Err(why) => self.decline(why.to_string()),
            },
        }
    }

    /// Runs worlds side by side in the same launches, each for its own steps (see
    /// [`world`]); Err says why they cannot run here together.
    pub(crate) fn run_worlds(&self, worlds: &[World]) -> Result<Vec<SegmentEnd>, Declined> {
        let longest_row = worlds.iter().map(|w| w.longest_row).max().unwrap_or(0);
        let longest_wall = worlds.iter().map(|w| w.longest_wall).max().unwrap_or(0);
        let [pair, wall, bucket] = *self.grown.lock().unwrap_or_else(|e| e.into_inner());
        let mut cap = match self.tight {
            false => Capacity {
                pair: (longest_row + longest_row / 4 + 4).max(pair),
                wall: (longest_wall + 4).max(wall),
                bucket: bucket.max(16),
            },
            true => Capacity {
                pair: longest_row.max(1).max(pair),
                wall: longest_wall.max(1).max(wall),
                bucket: bucket.max(2),
            },
        };
        for _ in 0..12 {
            // A panic inside wgpu (a lost device) is the device's failure, not the process's.
            let c = &self.ctx;
            let tried = c
                .failure
                .guard(&c.adapter, || Ok(self.try_run(worlds, cap)))
                .unwrap_or_else(|why| Err(Retry::Failed(why)));
            if matches!(tried, Err(Retry::Overflow(_))) {
                self.segments[2].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
            match tried {
                Ok((ends, overflowed)) => {
                    // Ended early at a chunk's start by an overflow: the next segment goes on
                    // from there with the room that was missing.
                    if let Some(code) = overflowed {
                        cap = cap.grown(code).map_err(Declined::Why)?;
                        self.segments[3].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                    let mut g = self.grown.lock().unwrap_or_else(|e| e.into_inner());
                    *g = [g[0].max(cap.pair), g[1].max(cap.wall), g[2].max(cap.bucket)];
                    return Ok(ends);
                }
                Err(Retry::Overflow(code)) => cap = cap.grown(code).map_err(Declined::Why)?,
                Err(Retry::Decline(why) | Retry::Failed(why)) => return Err(Declined::Why(why)),
                Err(Retry::Memory { needed, room }) => {
                    // The room that overflows showed was needed holds for the smaller batches.
                    let mut g = self.grown.lock().unwrap_or_else(|e| e.into_inner());
                    *g = [g[0].max(cap.pair), g[1].max(cap.wall), g[2].max(cap.bucket)];
                    return Err(Declined::Memory { needed, room });
                }
            }
        }
        Err(Declined::Why(format!(
            "its lists kept overflowing (pair rows of {}, wall rows of {}, buckets of {})",
            cap.pair, cap.wall, cap.bucket
        )))
    }

    /// Declines a segment: says why once per process (the steps then run stage by stage).
    pub(crate) fn decline<T>(&self, why: String) -> Option<T> {
        if self.ctx.failure().is_some() {
            // Said as the device's failure already; the steps run on the CPU.
            return None;
        }
        static SAID: std::sync::Once = std::sync::Once::new();
        SAID.call_once(|| {
            eprintln!("warning: the GPU runs this simulation stage by stage, copying the particles at every stage, because {why}");
        });
        None
    }
}

impl Launch<'_> {
    /// Records the launch in `pass` (a launch of no threads still runs one group: `begin`).
    fn dispatch(&self, pass: &mut wgpu::ComputePass) {
        let (x, y) = if self.threads == 0 {
            (1, 1)
        } else {
            groups(self.threads)
        };
        pass.set_pipeline(self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        match &self.indirect {
            Some((args, offset)) => pass.dispatch_workgroups_indirect(args, *offset),
            None => pass.dispatch_workgroups(x, y, 1),
        }
    }
}

/// Encodes `launches` as `encode` does, each in a pass of its own that writes its start and end
/// into `stamps` from query `2 * first` on (`crate::profile`).
fn encode_timed(
    encoder: &mut wgpu::CommandEncoder,
    launches: &[&Launch],
    stamps: &wgpu::QuerySet,
    first: u32,
) {
    for (k, l) in launches.iter().enumerate() {
        let at = 2 * (first + k as u32);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(l.name),
            timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                query_set: stamps,
                beginning_of_pass_write_index: Some(at),
                end_of_pass_write_index: Some(at + 1),
            }),
        });
        l.dispatch(&mut pass);
    }
}

fn encode(encoder: &mut wgpu::CommandEncoder, launches: &[&Launch]) {
    let mut pass = encoder.begin_compute_pass(&Default::default());
    for l in launches {
        l.dispatch(&mut pass);
    }
}

/// The overflow word of `ctrl`: a capacity to raise, or a particle the wall kernel cannot take.
fn check_overflow(words: &[u8]) -> Result<(), Retry> {
    let w: Vec<u32> = bytemuck::pod_collect_to_vec(words);
    match w[ctrl::OVERFLOW] {
        overflow::NONE => Ok(()),
        overflow::WALLS_KEPT => Err(Retry::Decline(
            "a particle touched more walls at once than the wall kernel keeps".to_string(),
        )),
        code => Err(Retry::Overflow(code)),
    }
}
