//! Device-resident steps: a whole segment of steps ([`dem::sim::segment`]) with the particles,
//! lists and histories kept on the GPU.
//!
//! Each step is one run of kernels with no host round trip: `begin` (the host's forced-rebuild
//! flag for the step), `integrate`, `check` (half-skin displacement, failures), the rebuild
//! kernels (`clear`, `bin`, `build_pairs`, `build_walls`, `sort_reverse`, `commit`; each returns
//! at once when no rebuild is due), then `pair_forces`, `wall_forces` and `particle_sums` with the
//! second half kick. The kernels of the check path are reused as they are; the lists they read
//! have a fixed capacity per particle, so a rebuild needs no prefix sums and no host: a particle's
//! pair row holds its j > i sorted by j (its history found by a merge with the old row), its
//! reverse row the sorted slots where it is j, so every particle sums its contacts in a fixed
//! order and results are deterministic on a given device. Cells are hashed into a power-of-two
//! table of fixed-capacity buckets (no grid bounds to know). A row or bucket that overflows is
//! reported through `ctrl`; the segment is then run again from its start (the host still holds
//! it) with twice the capacity.
//!
//! The host reads a few control words every [`CHUNK`] steps (to stop a failed run early), and
//! the state once at the end of the segment.

use dem::contact::ContactHistory;
use dem::geometry::Load;
use dem::neighbour::Pair;
use dem::sim::walls::WallCandidate;
use dem::sim::{Segment, SegmentEnd};

use crate::{
    element_row, f64s, flat, groups, ints_of, pair_table, params_of, props_of, row_width, state_of,
    vec3_at, GpuContext, GpuStages,
};

/// Steps between reads of the control words.
const CHUNK: u64 = 64;
/// Buckets per particle in the cell hash (rounded up to a power of two).
const BUCKETS_PER_PARTICLE: usize = 2;
const EMPTY: u32 = u32::MAX;

/// Capacities of the fixed-size rows.
#[derive(Clone, Copy, Debug)]
struct Capacity {
    pair: usize,
    wall: usize,
    bucket: usize,
}

/// Why a try stopped short.
enum Retry {
    /// A capacity was too small (`ctrl[3]`'s code).
    Overflow(u32),
    /// The segment cannot run here (why: too large for a binding, a particle with too many
    /// walls).
    Decline(String),
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
    geometry_loads: wgpu::ComputePipeline,
}

impl ResidentKernels {
    /// `pipeline(name, parts, with_common)` compiles a kernel from its parts.
    pub(crate) fn new(
        pipeline: &dyn Fn(&str, &[&str], bool) -> wgpu::ComputePipeline,
        elements: &str,
    ) -> ResidentKernels {
        const SHARED: &str = include_str!("wgsl/resident/shared.wgsl");
        ResidentKernels {
            begin: pipeline("begin", &[include_str!("wgsl/resident/begin.wgsl")], false),
            check: pipeline("check", &[include_str!("wgsl/resident/check.wgsl")], false),
            clear: pipeline("clear", &[include_str!("wgsl/resident/clear.wgsl")], false),
            bin: pipeline(
                "bin",
                &[SHARED, include_str!("wgsl/resident/bin.wgsl")],
                false,
            ),
            build_pairs: pipeline(
                "build_pairs",
                &[SHARED, include_str!("wgsl/resident/build_pairs.wgsl")],
                false,
            ),
            build_walls: pipeline(
                "build_walls",
                &[
                    SHARED,
                    elements,
                    include_str!("wgsl/resident/build_walls.wgsl"),
                ],
                false,
            ),
            sort_reverse: pipeline(
                "sort_reverse",
                &[include_str!("wgsl/resident/sort_reverse.wgsl")],
                false,
            ),
            commit: pipeline(
                "commit",
                &[include_str!("wgsl/resident/commit.wgsl")],
                false,
            ),
            geometry_loads: pipeline(
                "geometry_loads",
                &[include_str!("wgsl/resident/geometry_loads.wgsl")],
                false,
            ),
        }
    }
}

/// One kernel launch of a step: pipeline, bind group, threads.
struct Launch<'a> {
    pipeline: &'a wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    threads: u32,
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

    /// Copies `buffers` back (after what `encoder` holds) and waits for them.
    pub(crate) fn read_back(
        &self,
        mut encoder: wgpu::CommandEncoder,
        buffers: &[&wgpu::Buffer],
    ) -> Vec<Vec<u8>> {
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
        self.queue.submit([encoder.finish()]);
        for s in &staging {
            s.slice(..).map_async(wgpu::MapMode::Read, |r| {
                r.expect("mapping a read-back buffer");
            });
        }
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("waiting for the GPU");
        staging
            .iter()
            .map(|s| {
                s.slice(..)
                    .get_mapped_range()
                    .expect("a mapped buffer")
                    .to_vec()
            })
            .collect()
    }
}

impl GpuStages {
    /// Runs a segment on the device (see the module notes); None when it cannot.
    pub(crate) fn segment(&self, seg: &Segment) -> Option<SegmentEnd> {
        let n = seg.particles.len();
        if n == 0 || !Self::runs_pairs(&seg.inputs) {
            return None;
        }
        let lists = seg.lists;
        if lists.row_start.len() != n + 1 || seg.wall_start.len() != n + 1 {
            return None;
        }
        let mut longest_reverse = vec![0usize; n];
        for p in &lists.pairs {
            longest_reverse[p.j as usize] += 1;
        }
        let longest_row = (0..n)
            .map(|i| (lists.row_start[i + 1] - lists.row_start[i]) as usize)
            .chain(longest_reverse)
            .max()
            .unwrap_or(0);
        let longest_wall = (0..n)
            .map(|i| (seg.wall_start[i + 1] - seg.wall_start[i]) as usize)
            .max()
            .unwrap_or(0);
        let mut cap = Capacity {
            pair: longest_row + longest_row / 4 + 4,
            wall: longest_wall + 4,
            bucket: 16,
        };
        for _ in 0..12 {
            let tried = self.try_segment(seg, cap);
            if tried.is_err() {
                self.segments[2].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
            match tried {
                Ok(end) => return Some(end),
                Err(Retry::Overflow(1)) => cap.bucket *= 2,
                Err(Retry::Overflow(2 | 3)) => cap.pair *= 2,
                Err(Retry::Overflow(4)) => cap.wall *= 2,
                Err(Retry::Overflow(code)) => {
                    return self.decline(format!("an unknown overflow code {code}"))
                }
                Err(Retry::Decline(why)) => return self.decline(why),
            }
        }
        self.decline(format!(
            "its lists kept overflowing (pair rows of {}, wall rows of {}, buckets of {})",
            cap.pair, cap.wall, cap.bucket
        ))
    }

    /// Declines a segment: says why once per process (the steps then run stage by stage).
    fn decline(&self, why: String) -> Option<SegmentEnd> {
        static SAID: std::sync::Once = std::sync::Once::new();
        SAID.call_once(|| {
            eprintln!("warning: the GPU runs this simulation stage by stage, copying the particles at every stage, because {why}");
        });
        None
    }

    fn try_segment(&self, seg: &Segment, cap: Capacity) -> Result<SegmentEnd, Retry> {
        let c = &*self.ctx;
        let p = seg.particles;
        let n = p.len();
        let inputs = &seg.inputs;
        let pairs = n * cap.pair;
        let walls = n * cap.wall;
        let buckets = (BUCKETS_PER_PARTICLE * n).next_power_of_two().max(64);
        let geometries = inputs.geometries;
        let elements: usize = geometries.iter().map(|g| g.elements.len()).sum();
        let steps = seg.steps as usize;
        let moving_rows: usize = seg
            .track
            .moving
            .iter()
            .map(|&g| geometries[g].elements.len())
            .sum();
        let largest = [
            72 * n,
            4 * (steps + 1),
            128 * moving_rows * steps,
            64 * geometries.len() * steps,
            88 * pairs,
            80 * walls,
            4 * (6 * n + pairs),
            4 * buckets * cap.bucket,
            128 * elements,
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        if !c.fits(largest) || pairs >= u32::MAX as usize / 11 {
            return Err(Retry::Decline(format!(
                "its largest list ({:.2} GB) does not fit one binding of {} ({:.2} GB)",
                largest as f64 * 1e-9,
                c.adapter,
                c.max_binding as f64 * 1e-9
            )));
        }

        // The lists at the segment's start, in rows of fixed capacity.
        let mut pair_ij = vec![EMPTY; 2 * pairs];
        let mut pair_history = vec![0.0f64; 6 * pairs];
        let mut rows = vec![0u32; 6 * n + pairs];
        for i in 0..n {
            let (a, b) = (
                seg.lists.row_start[i] as usize,
                seg.lists.row_start[i + 1] as usize,
            );
            if b - a > cap.pair {
                return Err(Retry::Overflow(2));
            }
            for (k, pair) in seg.lists.pairs[a..b].iter().enumerate() {
                let q = i * cap.pair + k;
                pair_ij[2 * q] = pair.i;
                pair_ij[2 * q + 1] = pair.j;
                put_history(&mut pair_history, q, &pair.history);
            }
            rows[i] = (i * cap.pair) as u32;
            rows[n + i] = (i * cap.pair + b - a) as u32;
        }
        let mut cands = vec![EMPTY; 2 * walls];
        let mut wall_history = vec![0.0f64; 6 * walls];
        for i in 0..n {
            let (a, b) = (seg.wall_start[i] as usize, seg.wall_start[i + 1] as usize);
            if b - a > cap.wall {
                return Err(Retry::Overflow(4));
            }
            for (k, w) in seg.wall_candidates[a..b].iter().enumerate() {
                let q = i * cap.wall + k;
                cands[2 * q] = w.geometry as u32;
                cands[2 * q + 1] = w.element;
                put_history(&mut wall_history, q, &w.history);
            }
            rows[4 * n + i] = (i * cap.wall) as u32;
            rows[5 * n + i] = (i * cap.wall + b - a) as u32;
        }

        // Geometry: elements now, and per step the moving ones' elements and every velocity.
        let track = seg.track;
        let mut element_rows: Vec<f64> = Vec::with_capacity(16 * elements);
        let mut first = Vec::with_capacity(geometries.len());
        for g in geometries {
            first.push(element_rows.len() / 16);
            for e in &g.elements {
                element_rows.extend(element_row(e));
            }
        }
        // Moving geometries' elements at the start (the geometries hold them at the end).
        let mut at = 0;
        for &g in &track.moving {
            for k in 0..geometries[g].elements.len() {
                let row = element_row(&track.elements[0][at + k]);
                element_rows[16 * (first[g] + k)..16 * (first[g] + k + 1)].copy_from_slice(&row);
            }
            at += geometries[g].elements.len();
        }
        let geoms_at = |s: Option<usize>| -> Vec<f64> {
            geometries
                .iter()
                .enumerate()
                .flat_map(|(k, g)| {
                    let v = match s {
                        Some(s) => track.velocity[s][k],
                        None => g.velocity,
                    };
                    [
                        g.material as f64,
                        first[k] as f64,
                        v.linear.x,
                        v.linear.y,
                        v.linear.z,
                        v.angular.x,
                        v.angular.y,
                        v.angular.z,
                    ]
                })
                .collect()
        };
        let moving = !track.moving.is_empty();
        let (element_track, geoms_track) = if moving {
            let mut e = Vec::with_capacity(16 * moving_rows * steps);
            for s in 1..=steps {
                for el in &track.elements[s] {
                    e.extend(element_row(el));
                }
            }
            let mut v = Vec::with_capacity(8 * geometries.len() * steps);
            for s in 0..steps {
                v.extend(geoms_at(Some(s)));
            }
            (c.storage(&e), c.storage(&v))
        } else {
            (c.storage(&[0.0f64]), c.storage(&[0.0f64]))
        };
        let mut forced: Vec<u32> = track.rebuild.iter().map(|&r| r as u32).collect();
        forced.resize(steps + 1, 0);

        // Buffers.
        let params = inputs.params;
        let max_r = p.radius.iter().cloned().fold(0.0, f64::max);
        let cell = 1.01 * (2.0 * max_r + seg.pair_reach);
        let half_skin = 0.5 * params.skin;
        let copy_usage = wgpu::BufferUsages::COPY_DST;
        let storage_rw = |data: &[u8]| c.storage_with(data, copy_usage);
        let state = c.storage(&state_of(p));
        let mut load_data = flat(&[&p.force, &p.torque]);
        load_data.extend(&p.rolling_torque_limit);
        let loads = c.storage(&load_data);
        let props = c.storage(&props_of(p));
        let body = c.storage(&p.body);
        let ints = c.storage(&ints_of(p));
        let built = c.storage(&vec![0.0f64; 3 * n]);
        let par = c.storage(&params_of(
            params,
            false,
            true,
            inputs.materials.len(),
            inputs.cohesive,
        ));
        let counts = |threads: usize| {
            c.storage(&[
                n as u32,
                pairs as u32,
                pairs as u32,
                walls as u32,
                row_width(threads as u32),
            ])
        };
        let counts_n = counts(n);
        let counts_pairs = counts(pairs);
        let counts_buckets = counts(buckets);
        let moved = c.storage(&vec![0.0f64; n]);
        let outside = c.storage(&vec![0u32; n]);
        let status = c.storage(&vec![0u32; n]);
        let pair_ij = c.storage(&pair_ij);
        let pair_history = c.storage(&pair_history);
        let pair_output = c.storage(&vec![0.0f64; 11 * pairs]);
        let new_ij = c.storage(&vec![EMPTY; 2 * pairs]);
        let new_pair_history = c.storage(&vec![0.0f64; 6 * pairs]);
        let rows = c.storage(&rows);
        let cands = c.storage(&cands);
        let wall_history = c.storage(&wall_history);
        let wall_output = c.storage(&vec![0.0f64; 10 * walls]);
        let new_cands = c.storage(&vec![EMPTY; 2 * walls]);
        let new_wall_history = c.storage(&vec![0.0f64; 6 * walls]);
        let table = c.storage(&pair_table(inputs));
        let element_buf = storage_rw(bytemuck::cast_slice(&element_rows));
        let geoms = storage_rw(bytemuck::cast_slice(&geoms_at(None)));
        let forced = c.storage(&forced);
        let ctrl = c.storage(&[0u32, 1, EMPTY, 0, 0, 0, 0, 0]);
        let dims = c.storage(&[
            n as u32,
            cap.pair as u32,
            cap.wall as u32,
            buckets as u32,
            cap.bucket as u32,
            geometries.len() as u32,
            elements as u32,
            0,
        ]);
        let search = c.storage(&[
            1.0 / cell,
            seg.pair_reach,
            seg.wall_reach,
            half_skin * half_skin,
        ]);
        let bucket_count = c.storage(&vec![0u32; buckets]);
        let bucket_items = c.storage(&vec![0u32; buckets * cap.bucket]);
        let reverse_count = c.storage(&vec![0u32; n]);
        let geometry_loads = c.storage(&vec![0.0f64; 6 * geometries.len().max(1)]);

        let k = &c.resident;
        let launch = |pipeline, buffers: &[&wgpu::Buffer], threads: usize| Launch {
            pipeline,
            group: c.bind(pipeline, buffers),
            threads: threads as u32,
        };
        let rebuild = [
            launch(
                &k.clear,
                &[&counts_buckets, &ctrl, &bucket_count, &reverse_count, &dims],
                buckets,
            ),
            launch(
                &k.bin,
                &[
                    &state,
                    &counts_n,
                    &ctrl,
                    &bucket_count,
                    &bucket_items,
                    &dims,
                    &search,
                ],
                n,
            ),
            launch(
                &k.build_pairs,
                &[
                    &state,
                    &props,
                    &counts_n,
                    &ctrl,
                    &bucket_count,
                    &bucket_items,
                    &dims,
                    &search,
                    &pair_ij,
                    &pair_history,
                    &new_ij,
                    &new_pair_history,
                    &rows,
                    &reverse_count,
                    &built,
                ],
                n,
            ),
            launch(
                &k.build_walls,
                &[
                    &state,
                    &counts_n,
                    &props,
                    &ctrl,
                    &dims,
                    &search,
                    &element_buf,
                    &geoms,
                    &cands,
                    &wall_history,
                    &new_cands,
                    &new_wall_history,
                    &rows,
                ],
                n,
            ),
            launch(
                &k.sort_reverse,
                &[&counts_n, &ctrl, &rows, &reverse_count, &dims],
                n,
            ),
            launch(
                &k.commit,
                &[
                    &counts_n,
                    &ctrl,
                    &dims,
                    &pair_ij,
                    &pair_history,
                    &new_ij,
                    &new_pair_history,
                    &cands,
                    &wall_history,
                    &new_cands,
                    &new_wall_history,
                ],
                n,
            ),
        ];
        let check = launch(
            &k.check,
            &[&state, &counts_n, &moved, &outside, &status, &ctrl, &search],
            n,
        );
        let begin = launch(&k.begin, &[&ctrl, &forced], 0);
        let integrate = launch(
            &c.integrate,
            &[
                &state, &loads, &props, &body, &built, &par, &counts_n, &moved, &outside,
            ],
            n,
        );
        let forces = [
            launch(
                &c.pair_forces,
                &[
                    &state,
                    &props,
                    &ints,
                    &pair_ij,
                    &pair_history,
                    &pair_output,
                    &table,
                    &par,
                    &counts_pairs,
                ],
                pairs,
            ),
            launch(
                &c.wall_forces,
                &[
                    &state,
                    &props,
                    &ints,
                    &element_buf,
                    &geoms,
                    &cands,
                    &rows,
                    &wall_history,
                    &wall_output,
                    &table,
                    &par,
                    &counts_n,
                    &status,
                ],
                n,
            ),
            launch(
                &c.particle_sums,
                &[
                    &state,
                    &loads,
                    &props,
                    &body,
                    &pair_output,
                    &rows,
                    &wall_output,
                    &par,
                    &counts_n,
                ],
                n,
            ),
        ];

        // One step's launches, in order (the same every step).
        let step: Vec<&Launch> = [&begin, &integrate, &check]
            .into_iter()
            .chain(rebuild.iter())
            .chain(forces.iter())
            .collect();

        // The lists for the state at the start (their histories from the host's lists).
        let mut encoder = c.device.create_command_encoder(&Default::default());
        encode(&mut encoder, &rebuild.iter().collect::<Vec<_>>());
        let mut done = 0usize;
        let mut failed_at = None;
        let mut words = c.read_back(encoder, &[&ctrl]);
        check_overflow(&words[0])?;
        while done < steps {
            let chunk = (steps - done).min(CHUNK as usize);
            let mut encoder = c.device.create_command_encoder(&Default::default());
            for s in done..done + chunk {
                if moving {
                    let mut from = 16 * moving_rows * s;
                    for &g in &track.moving {
                        let len = 16 * geometries[g].elements.len();
                        encoder.copy_buffer_to_buffer(
                            &element_track,
                            8 * from as u64,
                            &element_buf,
                            8 * (16 * first[g]) as u64,
                            8 * len as u64,
                        );
                        from += len;
                    }
                    let row = 8 * geometries.len();
                    encoder.copy_buffer_to_buffer(
                        &geoms_track,
                        8 * (row * s) as u64,
                        &geoms,
                        0,
                        8 * row as u64,
                    );
                }
                encode(&mut encoder, &step);
            }
            done += chunk;
            words = c.read_back(encoder, &[&ctrl]);
            check_overflow(&words[0])?;
            let w: Vec<u32> = bytemuck::pod_collect_to_vec(&words[0]);
            if w[2] != EMPTY {
                failed_at = Some(w[2] as u64);
                break;
            }
        }
        // The last step's kick and walls, checked as every step's are.
        let mut encoder = c.device.create_command_encoder(&Default::default());
        encode(&mut encoder, &[&check]);
        let loads_launch = Launch {
            pipeline: &k.geometry_loads,
            group: c.bind(
                &k.geometry_loads,
                &[&dims, &rows, &cands, &wall_output, &geometry_loads],
            ),
            threads: geometries.len().max(1) as u32,
        };
        encode(&mut encoder, &[&loads_launch]);
        let out = c.read_back(
            encoder,
            &[
                &ctrl,
                &state,
                &loads,
                &pair_ij,
                &pair_history,
                &rows,
                &cands,
                &wall_history,
                &geometry_loads,
            ],
        );
        check_overflow(&out[0])?;
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
        if failed_at.is_none() && w[2] != EMPTY {
            failed_at = Some(w[2] as u64);
        }
        let mut end = segment_end(
            n,
            &out,
            w[4].saturating_sub(1) as u64,
            failed_at,
            geometries.len(),
        );
        end.steps_done = done as u64;
        Ok(end)
    }
}

fn encode(encoder: &mut wgpu::CommandEncoder, launches: &[&Launch]) {
    let mut pass = encoder.begin_compute_pass(&Default::default());
    for l in launches {
        let (x, y) = if l.threads == 0 {
            (1, 1)
        } else {
            groups(l.threads)
        };
        pass.set_pipeline(l.pipeline);
        pass.set_bind_group(0, &l.group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// The overflow word of `ctrl`: a capacity to raise, or a particle the wall kernel cannot take.
fn check_overflow(ctrl: &[u8]) -> Result<(), Retry> {
    let w: Vec<u32> = bytemuck::pod_collect_to_vec(ctrl);
    match w[3] {
        0 => Ok(()),
        5 => Err(Retry::Decline(
            "a particle touched more walls at once than the wall kernel keeps".to_string(),
        )),
        code => Err(Retry::Overflow(code)),
    }
}

fn put_history(out: &mut [f64], q: usize, h: &ContactHistory) {
    let (t, r) = (h.tangential, h.rolling);
    out[6 * q..6 * q + 6].copy_from_slice(&[t.x, t.y, t.z, r.x, r.y, r.z]);
}

fn history_at(h: &[f64], q: usize) -> ContactHistory {
    ContactHistory {
        tangential: vec3_at(h, 6 * q),
        rolling: vec3_at(h, 6 * q + 3),
    }
}

/// The host's view of the device after a segment: `out` is ctrl, state, loads, pair ij, pair
/// history, rows, wall candidates, wall history, geometry loads.
fn segment_end(
    n: usize,
    out: &[Vec<u8>],
    rebuilds: u64,
    failed_at: Option<u64>,
    geometries: usize,
) -> SegmentEnd {
    let s = f64s(&out[1]);
    let l = f64s(&out[2]);
    let ij: Vec<u32> = bytemuck::pod_collect_to_vec(&out[3]);
    let ph = f64s(&out[4]);
    let rows: Vec<u32> = bytemuck::pod_collect_to_vec(&out[5]);
    let cands: Vec<u32> = bytemuck::pod_collect_to_vec(&out[6]);
    let wh = f64s(&out[7]);
    let gl = f64s(&out[8]);
    let v = |base: usize| {
        (0..n)
            .map(|i| vec3_at(&s, base + 3 * i))
            .collect::<Vec<_>>()
    };
    let mut end = SegmentEnd {
        position: v(0),
        velocity: v(3 * n),
        angular_velocity: v(6 * n),
        force: (0..n).map(|i| vec3_at(&l, 3 * i)).collect(),
        torque: (0..n).map(|i| vec3_at(&l, 3 * n + 3 * i)).collect(),
        rolling_torque_limit: l[6 * n..7 * n].to_vec(),
        rebuilds,
        failed_at,
        ..Default::default()
    };
    for i in 0..n {
        for q in rows[i] as usize..rows[n + i] as usize {
            let history = history_at(&ph, q);
            if !history.is_empty() {
                end.pairs.push(Pair {
                    i: i as u32,
                    j: ij[2 * q + 1],
                    history,
                });
            }
        }
    }
    end.wall_start.push(0);
    for i in 0..n {
        for c in rows[4 * n + i] as usize..rows[5 * n + i] as usize {
            let history = history_at(&wh, c);
            if !history.is_empty() {
                end.wall_candidates.push(WallCandidate {
                    geometry: cands[2 * c] as u16,
                    element: cands[2 * c + 1],
                    history,
                });
            }
        }
        end.wall_start.push(end.wall_candidates.len() as u32);
    }
    end.geometry_loads = (0..geometries)
        .map(|g| Load {
            force: vec3_at(&gl, 6 * g),
            torque: vec3_at(&gl, 6 * g + 3),
        })
        .collect();
    end
}
