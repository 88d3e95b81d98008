//! The DEM engine's stages on a GPU, through wgpu's Vulkan back end (the one with f64 shaders;
//! Mesa's lavapipe where there is no GPU).
//!
//! Design notes.
//!
//! - **Where it plugs in.** [`GpuStages`] implements the engine's stage boundary,
//!   [`dem::sim::Backend`], two ways. Scenes run as *segments* (`Backend::run_segment`, the
//!   `resident` module): `dem::sim::Simulation::run` hands over whole runs of steps (up to the
//!   end of the call or the next step at which an extension such as a factory has work), and the
//!   particles, pair and wall lists, contact histories, clump bodies and bonds stay on the device
//!   for all of them; lists are rebuilt on the device (hashed cell buckets, fixed-capacity
//!   sorted rows, histories merged from the old rows); the host reads a few control words every
//!   64 steps and the state once at the end. Scenes with polyhedra (whose contacts are the
//!   host's), the Hooke law or an extension that works on the host at every step, and any
//!   segment the device declines, run stage by stage: the pipeline in
//!   `Simulation::step` calls integrate, pair forces, wall forces and particle sums, and each
//!   stage copies its arrays to the device and back (the check path).
//! - **What runs on the GPU.** Integration, Hertz-Mindlin pair forces with or without JKR
//!   cohesion, the tangential spring and both rolling models (cdt, epsd), wall contacts with every
//!   element kind (planes, rectangles, discs, cylinder shells, triangles; moving geometry through
//!   its velocity field; faces before edges, as `dem::sim::walls::wall_contacts` does; the JKR
//!   cut-off), the particle sums with the second half kick, and (in segments) the neighbour and
//!   wall-candidate searches, the geometry loads and the bonds (`resident::bonds`,
//!   `wgsl/bonds/`: each bond's incremental update and breakage test, each sphere's bond forces
//!   summed in bond order with local damping, the breakages logged by the host afterwards; each
//!   world of a batch has its own bonds). On the check path the Hooke law, a stage
//!   whose arrays would pass the device's largest binding, and a particle touching more than 32
//!   walls at once are handed to the CPU back end inside the stage
//!   ([`GpuStages::handed_to_cpu`] counts them); in a segment the largest lists (the pair and
//!   wall histories and the wall outputs) are bound in up to four parts (`kernels::PARTS`), and
//!   a segment whose lists pass that, or the largest binding for the others, is declined with a
//!   warning saying so ([`GpuStages::segments`] counts both), so any scene runs.
//! - **How it is chosen.** [`register`] makes "gpu" one of the engine's named back ends
//!   (`dem::sim::make_backend`), built on one process-wide context ([`shared_context`]), so scene,
//!   test and study files and `--backend gpu` can name it.
//! - **Batches.** A segment runs as a *world*; several worlds (simulations of one batch group,
//!   `dem::sim::in_batch_group`, such as a study stage's jobs) run side by side in the same
//!   launches, each with its own parameters and number of steps ([`batch`], `resident::world`),
//!   and each ends with the bits it gets alone.
//! - **Precision.** Positions, velocities, forces and history are f64 on the device
//!   (`wgpu::Features::SHADER_F64`; Mesa's lavapipe has it, so the kernels are tested on any
//!   machine). WGSL's f64 has only the basic operations and `sqrt`, which is all these kernels use.
//!   Results agree with the CPU to round-off (a GPU compiler may fuse a multiply and an add, and a
//!   segment keeps the particles in the order it got them where the CPU re-sorts them at each
//!   rebuild, so sums run in another order); they are deterministic for a given device, since
//!   every thread writes its own slots and every particle sums its slots in a fixed order.
//! - **Failures.** A context that cannot be made (no Vulkan adapter with f64 shaders, a kernel the
//!   driver refuses) is an error naming the adapter. A particle that stops being finite or leaves
//!   the domain in a segment stops its world at once and the segment within two chunks of 64
//!   steps (the host reads one chunk's words while the next runs), with the step it happened
//!   in. A device lost in the middle of a run (a driver reset), memory the driver refuses, or any error wgpu
//!   reports outside a scope is recorded as the context's failure ([`GpuContext::failure`],
//!   the `failure` module), said once on stderr, and never a panic: from then on each stage runs
//!   on the CPU from the state the host holds, segments are declined, and a new simulation that
//!   asks for "gpu" gets the CPU with the failure as the reason (`dem::sim::resolve_backend`), so a
//!   study goes on, on the CPU (`tests/device_lost.rs`).
//! - **What runs where** is declared where it is written: a contact law's `ContactLaw::ON_GPU`
//!   (Hertz-Mindlin's is true; [`laws_on_gpu`]), an extension's `StepExtension::on_device`
//!   (bonds run in segments on the device, `OnDevice::InSegments`, and on the host when a scene
//!   steps stage by stage; a factory works between segments). `Simulation::choose_backend`
//!   tells the user both.
//! - **Kernels** are WGSL files in `src/wgsl/` (the segment kernels in `src/wgsl/resident/`),
//!   each put together with the shared parts it uses (`vector.wgsl`, vector helpers;
//!   `common.wgsl`, the accessors of `state`, `props`, `params` and `counts`; `spin.wgsl`, the
//!   spin kick; `half_kick.wgsl`, the second half kick; `contact.wgsl`, the contact law that pairs
//!   and walls share; `pair_contact.wgsl`, a particle pair's contact; `contact_rows.wgsl`,
//!   the stage contact kernels' history and output rows; `elements.wgsl`, the closest point of a
//!   wall element; `state_writes.wgsl`, `load_reads.wgsl` and `load_writes.wgsl`, vectors into
//!   `state` and to and from `loads`; `bodies/rigid.wgsl`, the clumps' rigid-body steps;
//!   `resident/shared.wgsl`, the segment's list sentinel and cell hash;
//!   `resident/history_halves.wgsl`, the segment's pair histories in two halves by the step's
//!   parity). One
//!   function, `kernels::kernel_sources`, composes every kernel; the context compiles what it
//!   returns, and the crate's tests parse and validate the same text with naga, so a kernel that
//!   does not compile fails `cargo test` on any machine. Geometry motion stays in the pipeline
//!   on the host (a segment gets the geometry poses of every step from it); clump bodies move on
//!   the device in segments (`resident::bodies`, `wgsl/bodies/`: the pipeline's clump stages,
//!   quaternions in glam's order) and on the host stage by stage.
//! - **The data contract.** Every buffer the host and the kernels share (a world's params block,
//!   the material pair table, element and geometry rows, contact histories, the force kernels'
//!   outputs, the particles' blocks of N in `state`, `loads`, `props`, `ints` and `rows`, the
//!   `counts` words, and the segment's `dims`, `search` and `ctrl` words with the overflow codes)
//!   is laid out once, in the `layout` module: named places that the host's writers and readers
//!   index with, and from which every kernel's source gets the same places as WGSL constants
//!   with one prefix per buffer (`P_STEPPING`, `H_ROLLING`, `S_VELOCITY * n + 3u * i`). No
//!   kernel reads a laid-out buffer by number: a test scans the WGSL files for numbered places,
//!   so a moved field cannot be half moved.

pub mod batch;
mod failure;
mod kernels;
mod layout;
mod pack;
mod pool;
pub mod profile;
mod resident;
mod stages;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

use dem::contact::ContactModel;
use dem::neighbour::NeighbourList;
use dem::particles::Particles;
use dem::sim::walls::WallLists;
use dem::sim::{
    Anchors, Backend, CpuBackend, Moved, Segment, SegmentEnd, SimulationParams, StepInputs,
};

/// Bytes of `state` per particle, the largest of the per-particle buffers.
pub(crate) const STATE_BYTES: usize = 8 * layout::state::LEN;

/// Threads per workgroup, as the kernels declare (all but `begin`, one workgroup of its own).
const WORKGROUP: u32 = 64;
/// The usage of every storage buffer: bound by kernels, copied to and from.
const STORAGE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);
/// Most workgroups along one dispatch dimension (WebGPU's guaranteed limit).
const MAX_GROUPS: u32 = 65_535;

/// The share of the device's memory a batch may take where `DEMCAL_GPU_MEMORY` does not say: the
/// rest is the driver's, the read-back copies' and other programs'.
const MEMORY_SHARE: f64 = 0.75;

/// The device memory a batch may take, in bytes: `DEMCAL_GPU_MEMORY` where it is set (bytes, as
/// `8e9` or `8000000000`), else [`MEMORY_SHARE`] of the adapter's largest device-local heap (a
/// CPU driver's is the host's memory), else no bound (the driver's out-of-memory error then
/// splits a batch, `resident::run`).
fn memory_budget(adapter: &wgpu::Adapter) -> Result<u64, String> {
    if let Ok(v) = std::env::var("DEMCAL_GPU_MEMORY") {
        return memory_from(&v);
    }
    Ok(device_local_heap(adapter).map_or(u64::MAX, |h| (h as f64 * MEMORY_SHARE) as u64))
}

/// `DEMCAL_GPU_MEMORY`'s value as bytes.
fn memory_from(v: &str) -> Result<u64, String> {
    match v.trim().parse::<f64>() {
        Ok(b) if b.is_finite() && b >= 1.0 && b < u64::MAX as f64 => Ok(b as u64),
        _ => Err(format!(
            "DEMCAL_GPU_MEMORY={v}: expected the bytes of device memory a batch may take, a number of at least 1 (such as 8e9)"
        )),
    }
}

/// The size of the adapter's largest device-local memory heap, in bytes, from Vulkan (wgpu does
/// not report it); None where the adapter is not Vulkan's or reports none.
fn device_local_heap(adapter: &wgpu::Adapter) -> Option<u64> {
    // SAFETY: the Vulkan adapter is only read, through its own instance, while wgpu holds it; no
    // handle is created or destroyed.
    let hal = unsafe { adapter.as_hal::<wgpu::hal::api::Vulkan>() }?;
    let instance = hal.shared_instance().raw_instance();
    // SAFETY: the physical device belongs to this instance, which outlives the call.
    let props =
        unsafe { instance.get_physical_device_memory_properties(hal.raw_physical_device()) };
    props
        .memory_heaps_as_slice()
        .iter()
        .filter(|h| h.flags.contains(ash::vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
}

/// A GPU with f64 shaders and the compiled kernels.
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: String,
    /// The largest storage buffer a kernel can bind, in bytes.
    max_binding: u64,
    /// The numbers of a part of a list bound in parts (`kernels::part_numbers`).
    part_numbers: usize,
    /// The most parts a segment's split lists took (`parts_used`).
    parts_used: std::sync::atomic::AtomicUsize,
    /// The device memory a batch of worlds may take, in bytes ([`memory_budget`]).
    memory: u64,
    /// The device's first failure; from then on nothing runs on it (`failure`).
    failure: Arc<failure::Failure>,
    /// The buffers of the last finished segment, for the next to reuse (`pool`).
    pool: pool::Pool,
    integrate: wgpu::ComputePipeline,
    pair_forces: wgpu::ComputePipeline,
    particle_sums: wgpu::ComputePipeline,
    wall_forces: wgpu::ComputePipeline,
    resident: resident::ResidentKernels,
}

impl GpuContext {
    /// The best Vulkan adapter with f64 shaders: a discrete GPU before an integrated or virtual
    /// one before a CPU driver (lavapipe). The error says what is missing.
    pub fn new() -> Result<GpuContext, String> {
        Self::open(None)
    }

    /// As [`Self::new`], binding at most `bytes` at once where the device would bind more: what
    /// the tests of lists split across bindings and of scenes too large for them use.
    #[doc(hidden)]
    pub fn with_binding_limit(bytes: u64) -> Result<GpuContext, String> {
        Self::open(Some(bytes))
    }

    fn open(binding_limit: Option<u64>) -> Result<GpuContext, String> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        let without: Vec<String> = adapters
            .iter()
            .filter(|a| !a.features().contains(wgpu::Features::SHADER_F64))
            .map(|a| a.get_info().name)
            .collect();
        let adapter = adapters
            .into_iter()
            .filter(|a| a.features().contains(wgpu::Features::SHADER_F64))
            .min_by_key(|a| rank(a.get_info().device_type))
            .ok_or_else(|| {
                if without.is_empty() {
                    "no Vulkan adapter; on Linux without a GPU, Mesa's lavapipe provides one (apt-get install mesa-vulkan-drivers)".to_string()
                } else {
                    format!(
                        "no Vulkan adapter with f64 shaders, which the GPU stages need ({} lack them)",
                        without.join(", ")
                    )
                }
            })?;
        let info = adapter.get_info();
        // Timestamp queries where the device has them: the kernel profile of `profile` reads them.
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let optional = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("demcal"),
            required_features: wgpu::Features::SHADER_F64 | optional,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| format!("the GPU {} refused a device: {e}", info.name))?;
        let max_binding = device
            .limits()
            .max_storage_buffer_binding_size
            .min(binding_limit.unwrap_or(u64::MAX));
        // A kernel the driver refuses is an error, not a panic.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        // Every kernel as `kernels::kernel_sources` composes it (the sources naga checks in the
        // crate's tests), but for the variants in parts where the device allows a kernel fewer
        // storage bindings than one of them takes: a segment that needs them is then declined.
        let sources = kernels::kernel_sources(max_binding);
        let allowed = device.limits().max_storage_buffers_per_shader_stage as usize;
        let in_parts = sources
            .iter()
            .filter(|(name, _)| kernels::in_parts(name))
            .all(|(_, source)| source.matches("@binding(").count() <= allowed);
        let mut pipelines: std::collections::HashMap<&str, wgpu::ComputePipeline> = sources
            .into_iter()
            .filter(|(name, _)| in_parts || !kernels::in_parts(name))
            .map(|(name, source)| {
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(name),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(name),
                    layout: None,
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                });
                (name, pipeline)
            })
            .collect();
        let mut take = |name: &str| {
            pipelines
                .remove(name)
                .unwrap_or_else(|| panic!("no kernel {name} in kernels::kernel_sources"))
        };
        let integrate = take("integrate");
        let pair_forces = take("pair_forces");
        let particle_sums = take("particle_sums");
        let wall_forces = take("wall_forces");
        let resident = resident::ResidentKernels::new(&mut take, in_parts);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!(
                "the GPU {} refused the kernels: {}",
                info.name,
                e.to_string().replace('\n', " ")
            ));
        }
        let memory = memory_budget(&adapter)?;
        // From here on a lost device or an error outside a scope is recorded, not a panic.
        let failure = Arc::new(failure::Failure::default());
        {
            let (lost, name) = (failure.clone(), info.name.clone());
            device.set_device_lost_callback(move |reason, message| {
                lost.record(format!(
                    "the GPU {name} was lost ({reason:?}): {}",
                    failure::one_line(&message)
                ))
            });
            let (error, name) = (failure.clone(), info.name.clone());
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                error.record(format!(
                    "the GPU {name} failed: {}",
                    failure::one_line(&e.to_string())
                ))
            }));
        }
        Ok(GpuContext {
            max_binding,
            part_numbers: kernels::part_numbers(max_binding),
            parts_used: Default::default(),
            memory,
            failure,
            pool: Default::default(),
            adapter: format!("{} ({:?})", info.name, info.backend),
            device,
            queue,
            integrate,
            pair_forces,
            particle_sums,
            wall_forces,
            resident,
        })
    }

    /// The adapter's name and API, for logs and benchmarks.
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// The device memory a batch of worlds may take, in bytes: a batch that needs more is packed
    /// into several that fit ([`memory_budget`]).
    pub fn memory_budget(&self) -> u64 {
        self.memory
    }

    /// This context with `bytes` of room for a batch instead (as `DEMCAL_GPU_MEMORY` sets it):
    /// for a GPU shared with other programs, and the tests of the packing.
    pub fn with_memory_budget(mut self, bytes: u64) -> GpuContext {
        self.memory = bytes;
        self
    }

    /// Whether the device has timestamp queries, which the kernel profile needs
    /// (`DEMCAL_GPU_PROFILE=1`, [`profile`]).
    pub fn has_timestamps(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Why the device stopped (lost, out of memory, an error wgpu reported), if it did: from then
    /// on every stage runs on the CPU and no segment on the device.
    pub fn failure(&self) -> Option<String> {
        self.failure.get()
    }

    /// Destroys the device, as a driver reset loses it: what the tests of the fallback to the CPU
    /// use. Nothing runs on this context afterwards.
    #[doc(hidden)]
    pub fn lose_device(&self) {
        self.device.destroy();
    }

    /// Whether arrays of `bytes` (the largest of a stage) fit one binding, and the stage's
    /// indices fit u32 (`PO_LEN * q` for a pair's output row).
    fn fits(&self, bytes: usize) -> bool {
        (bytes as u64) <= self.max_binding && bytes / 8 < u32::MAX as usize
    }

    /// A storage buffer holding `data` (at least 8 bytes: bindings cannot be empty), which
    /// copies may read and write.
    fn storage<T: bytemuck::Pod>(&self, data: &[T]) -> wgpu::Buffer {
        self.storage_with(bytemuck::cast_slice(data), wgpu::BufferUsages::empty())
    }

    /// A storage buffer holding `bytes`, with `usage` besides. Made unmapped and written through
    /// the queue (before the next submission), rather than mapped at creation: a buffer the
    /// device has no memory for is then an out-of-memory error that a scope catches
    /// (`resident::run` packs the batch smaller), where a mapped one would panic in wgpu.
    fn storage_with(&self, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let padded;
        let contents = if bytes.len() < 8 || !bytes.len().is_multiple_of(4) {
            let len = bytes.len().max(8).next_multiple_of(4);
            padded = [bytes, &vec![0u8; len - bytes.len()]].concat();
            &padded[..]
        } else {
            bytes
        };
        let buffer = self.scratch(contents.len() as u64, STORAGE_USAGE | usage);
        // Every byte is written, so a buffer from the pool holds nothing of its last use.
        self.queue.write_buffer(&buffer, 0, contents);
        buffer
    }

    /// A storage buffer of `len` zeros of `T` (at least 8 bytes, as [`Self::storage`]), cleared
    /// on the device by `encoder` rather than written from the host: most of a segment's lists
    /// and scratch start as zeros, and a buffer from the pool still holds its last use.
    fn zeros<T: bytemuck::Pod>(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        len: usize,
    ) -> wgpu::Buffer {
        let size = (len * std::mem::size_of::<T>()).max(8).next_multiple_of(4);
        let buffer = self.scratch(size as u64, STORAGE_USAGE);
        encoder.clear_buffer(&buffer, 0, None);
        buffer
    }

    /// A buffer of `size` bytes and `usage` whose contents are written before they are read:
    /// one kept from the last segment (`pool`) where one fits, else a new one.
    pub(crate) fn scratch(&self, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.pool.take(size, usage).unwrap_or_else(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size,
                usage,
                mapped_at_creation: false,
            })
        })
    }

    /// The most bindings a segment's pair or wall histories or wall outputs were split across
    /// (`kernels::PARTS` at most), since the context was made: 1 where each fit one.
    #[doc(hidden)]
    pub fn parts_used(&self) -> usize {
        self.parts_used.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Buffers a segment took from those the last one left rather than made, since the
    /// context was made.
    #[doc(hidden)]
    pub fn buffers_reused(&self) -> u64 {
        self.pool.reused()
    }

    /// Runs `pipeline` over `threads` threads with `buffers` bound in order, then reads back the
    /// buffers listed in `read` (indices into `buffers`).
    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        threads: u32,
        read: &[usize],
    ) -> Result<Vec<Vec<u8>>, String> {
        let group = self.bind(pipeline, buffers);
        let (x, y) = groups(threads);
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        let read: Vec<&wgpu::Buffer> = read.iter().map(|&k| buffers[k]).collect();
        self.read_back(encoder, &read)
    }
}

/// Workgroups for `threads` threads: along x, and rows of `MAX_GROUPS` along y beyond that.
fn groups(threads: u32) -> (u32, u32) {
    let g = threads.div_ceil(WORKGROUP).max(1);
    if g <= MAX_GROUPS {
        (g, 1)
    } else {
        (MAX_GROUPS, g.div_ceil(MAX_GROUPS))
    }
}

/// Row width of a dispatch in threads (what `thread_index` multiplies y by).
fn row_width(threads: u32) -> u32 {
    groups(threads).0 * WORKGROUP
}

/// The process's GPU context, made on first use: compiling the kernels takes a moment, and every
/// simulation of a process (a study's runs, a batch) shares one device.
pub fn shared_context() -> Result<Arc<GpuContext>, String> {
    static SHARED: OnceLock<Result<Arc<GpuContext>, String>> = OnceLock::new();
    SHARED
        .get_or_init(|| GpuContext::new().map(Arc::new))
        .clone()
}

/// Registers the back end "gpu" with the engine (`dem::sim::make_backend`), so that scene files,
/// test files, studies and `--backend gpu` can choose it. Call once at start-up.
pub fn register() {
    dem::sim::register_backend("gpu", || {
        let ctx = shared_context()?;
        // A device that failed earlier in this process: the simulation runs on the CPU, and
        // `choose_backend` / `resolve_backend` say why.
        if let Some(failure) = ctx.failure() {
            return Err(failure);
        }
        let stages = GpuStages::with_context(ctx);
        Ok(Box::new(match dem::sim::batch_group() {
            Some(group) => stages.in_batch_group(group),
            None => stages,
        }))
    });
}

/// The engine's stages on a GPU (see the crate notes for what runs there).
#[derive(Clone)]
pub struct GpuStages {
    ctx: Arc<GpuContext>,
    /// Stage calls handed to the CPU back end (a cohesive scene, the Hooke law, arrays too large
    /// for one binding, a particle touching more walls than the wall kernel keeps).
    handed_to_cpu: Arc<AtomicUsize>,
    /// Segments run on the device, segments declined (then stepped stage by stage), tries run
    /// again with more room after a list overflowed, and segments an overflow ended early.
    segments: Arc<[AtomicUsize; 4]>,
    /// Lists start with no room to spare ([`Self::with_tight_lists`]).
    tight: bool,
    /// The batch group these stages joined, if any (see [`batch`]).
    member: Option<Arc<batch::Member>>,
    /// The largest list capacities (pair row, wall row, bucket) a segment of these stages has
    /// needed: the next segments start from them, so that a scene whose rows grew past its first
    /// capacities reruns one segment, not each.
    grown: Arc<std::sync::Mutex<[usize; 3]>>,
}

impl GpuStages {
    pub fn new() -> Result<GpuStages, String> {
        Ok(GpuStages::with_context(Arc::new(GpuContext::new()?)))
    }

    /// Stages on a context already made (compiling the kernels takes a moment).
    pub fn with_context(ctx: Arc<GpuContext>) -> GpuStages {
        GpuStages {
            ctx,
            handed_to_cpu: Arc::new(AtomicUsize::new(0)),
            segments: Arc::default(),
            grown: Arc::default(),
            member: None,
            tight: false,
        }
    }

    /// These stages with lists that start with no room to spare (each row as long as the longest
    /// at the start), so that they overflow as soon as one grows, and chunks of 8 steps: what the
    /// tests of the overflow paths use (a run again, a segment ended early). The results are the
    /// same.
    #[doc(hidden)]
    pub fn with_tight_lists(mut self) -> GpuStages {
        self.tight = true;
        self
    }

    /// These stages, joined to batch `group`: their segments run in the same launches as those of
    /// the group's other members that run at the same time (see [`batch`]).
    pub fn in_batch_group(mut self, group: u64) -> GpuStages {
        self.member = Some(Arc::new(batch::join(group)));
        self
    }

    /// How many stage calls went to the CPU back end so far.
    pub fn handed_to_cpu(&self) -> usize {
        self.handed_to_cpu.load(Ordering::Relaxed)
    }

    /// Segments that an overflow ended early, at the start of the chunk in which it happened
    /// (the next segment went on from there with more room) instead of running again from their
    /// start; these are not among the tries of [`Self::segments`].
    pub fn segments_ended_early(&self) -> usize {
        self.segments[3].load(Ordering::Relaxed)
    }

    /// Segments of steps run with the state on the device, segments declined (a list too large
    /// for one binding, a particle touching more walls than the wall kernel keeps), and tries run
    /// again with more room after a pair row, reverse row, wall row or cell bucket overflowed.
    pub fn segments(&self) -> (usize, usize, usize) {
        let [run, declined, retried, _] = &*self.segments;
        (
            run.load(Ordering::Relaxed),
            declined.load(Ordering::Relaxed),
            retried.load(Ordering::Relaxed),
        )
    }

    fn to_cpu(&self) -> CpuBackend {
        self.handed_to_cpu.fetch_add(1, Ordering::Relaxed);
        CpuBackend
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether the contact stages run on the GPU for these inputs: a law that declares it
    /// (`ContactLaw::ON_GPU`: Hertz-Mindlin, with or without JKR cohesion), between spheres (the
    /// Hooke law and polyhedra run on the CPU).
    pub fn runs_pairs(inputs: &StepInputs) -> bool {
        inputs.params.contact_model.on_gpu() && inputs.polyhedra.is_none()
    }
}

impl Backend for GpuStages {
    fn name(&self) -> &'static str {
        "gpu"
    }

    fn remarks(&self, inputs: &StepInputs) -> Vec<String> {
        let mut r = vec![format!("on {}", self.ctx.adapter)];
        if inputs.polyhedra.is_some() {
            r.push("polyhedral particles' contacts run on the CPU, and the simulation stage by stage with the particles copied to the device and back at every stage (slower than the CPU)".to_string());
        } else if !Self::runs_pairs(inputs) {
            r.push(format!(
                "the {} contact law runs on the CPU (the GPU stages run {}), and the simulation stage by stage with the particles copied to the device and back at every stage (slower than the CPU)",
                inputs.params.contact_model.name(),
                laws_on_gpu().join(", ")
            ));
        }
        r
    }

    fn runs_segments(&self, inputs: &StepInputs) -> bool {
        // Clumps run with the segment (their bodies on the device); polyhedra's contacts are the
        // host's, which `runs_pairs` says.
        Self::runs_pairs(inputs) && self.ctx.failure().is_none()
    }

    fn run_segment(&self, segment: &Segment) -> Option<SegmentEnd> {
        let end = self.segment(segment);
        let counter = if end.is_some() {
            &self.segments[0]
        } else {
            &self.segments[1]
        };
        counter.fetch_add(1, Ordering::Relaxed);
        end
    }

    fn integrate(
        &self,
        p: &mut Particles,
        anchors: Anchors,
        params: &SimulationParams,
        clumps: bool,
    ) -> Result<Moved, usize> {
        assert_eq!(
            anchors.build.len(),
            p.len(),
            "positions at the last build, one per particle"
        );
        // The guard holds only the device's work; the CPU's runs outside it (`stages`).
        let c = &self.ctx;
        match c.failure.guard(&c.adapter, || {
            self.integrate_device(p, anchors, params, clumps)
        }) {
            Ok(Some(moved)) => moved,
            Ok(None) | Err(_) => self.to_cpu().integrate(p, anchors, params, clumps),
        }
    }

    fn pair_forces(&self, p: &Particles, lists: &mut NeighbourList, inputs: &StepInputs) {
        let c = &self.ctx;
        let done = c
            .failure
            .guard(&c.adapter, || self.pair_forces_device(p, lists, inputs));
        if done != Ok(true) {
            self.to_cpu().pair_forces(p, lists, inputs);
        }
    }

    fn wall_forces(&self, p: &Particles, walls: &mut WallLists, inputs: &StepInputs) {
        assert_eq!(
            walls.start().len(),
            p.len() + 1,
            "wall row starts: one per particle and one more"
        );
        let c = &self.ctx;
        let done = c
            .failure
            .guard(&c.adapter, || self.wall_forces_device(p, walls, inputs));
        if done != Ok(true) {
            self.to_cpu().wall_forces(p, walls, inputs);
        }
    }

    fn particle_sums(
        &self,
        p: &mut Particles,
        lists: &NeighbourList,
        walls: &WallLists,
        inputs: &StepInputs,
        kick: bool,
    ) {
        // The CPU stage indexes these rows for every particle; they must be there.
        for (what, len) in [
            ("pair row starts", lists.row_start.len()),
            ("reverse row starts", lists.reverse_start.len()),
            ("wall row starts", walls.start().len()),
        ] {
            assert_eq!(len, p.len() + 1, "{what}: one per particle and one more");
        }
        let c = &self.ctx;
        let done = c.failure.guard(&c.adapter, || {
            self.particle_sums_device(p, lists, walls, inputs, kick)
        });
        if done != Ok(true) {
            self.to_cpu().particle_sums(p, lists, walls, inputs, kick);
        }
    }
}

/// The contact laws whose contacts the GPU stages run (`ContactLaw::ON_GPU`).
pub fn laws_on_gpu() -> Vec<&'static str> {
    ContactModel::NAMES
        .iter()
        .copied()
        .filter(|&n| ContactModel::from_name(n).is_some_and(|m| m.on_gpu()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `contact.wgsl` has Hertz-Mindlin's force (with JKR) and no other: a law that declares
    /// `ON_GPU` must bring its WGSL, and this list changes with it.
    #[test]
    fn the_laws_declared_on_the_gpu_are_the_ones_the_kernels_have() {
        assert_eq!(laws_on_gpu(), ["hertz_mindlin"]);
        assert!(!ContactModel::from_name("hooke").unwrap().on_gpu());
    }

    #[test]
    fn dispatches_cover_every_thread_once() {
        assert_eq!(groups(0), (1, 1));
        assert_eq!(groups(64), (1, 1));
        assert_eq!(groups(65), (2, 1));
        let big = 64 * MAX_GROUPS + 1;
        assert_eq!(groups(big), (MAX_GROUPS, 2));
        // thread_index = x + y * row_width reaches every thread below `big`, and no more rows.
        let (x, y) = groups(big);
        assert!(x * WORKGROUP * y >= big);
        assert_eq!(row_width(big), MAX_GROUPS * WORKGROUP);
    }

    #[test]
    fn the_memory_budget_is_read_as_bytes_and_a_wrong_one_is_named() {
        assert_eq!(memory_from("8e9"), Ok(8_000_000_000));
        assert_eq!(memory_from(" 123456 "), Ok(123_456));
        for wrong in ["", "8GB", "0", "-1", "nan", "inf", "1e30"] {
            let e = memory_from(wrong).unwrap_err();
            assert!(
                e.starts_with(&format!("DEMCAL_GPU_MEMORY={wrong}: expected the bytes")),
                "{e}"
            );
        }
    }
}
