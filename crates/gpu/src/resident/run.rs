//! One try of a batch of worlds on the device at given capacities: buffers, the launch list of a
//! step, the steps in chunks of [`CHUNK`], and the read-back of every world's end.

use dem::sim::SegmentEnd;

use super::world::{Merged, World};
use super::{check_overflow, encode, Capacity, Launch, Retry, BUCKETS_PER_PARTICLE, CHUNK, EMPTY};
use crate::{row_width, GpuStages};

impl GpuStages {
    pub(super) fn try_run(
        &self,
        worlds: &[World],
        cap: Capacity,
    ) -> Result<Vec<SegmentEnd>, Retry> {
        let c = &*self.ctx;
        let n: usize = worlds.iter().map(|w| w.n).sum();
        let pairs = n * cap.pair;
        let walls = n * cap.wall;
        let buckets = (BUCKETS_PER_PARTICLE * n).next_power_of_two().max(64);
        let steps = worlds.iter().map(|w| w.steps).max().unwrap_or(0) as usize;
        let geometries: usize = worlds.iter().map(|w| w.geometry_first.len()).sum();
        let elements: usize = worlds.iter().map(|w| w.elements.len() / 16).sum();
        let m = Merged::new(worlds, cap).map_err(Retry::Overflow)?;
        // Every buffer of the run, in bytes, against one binding.
        let largest = [
            72 * n,
            4 * (steps + 1),
            8 * m.element_track.len(),
            8 * m.geoms_track.len(),
            8 * m.table.len(),
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
        let moving = !m.moving.is_empty();
        let moving_rows = m.moving_rows();

        // Buffers.
        let storage_rw = |data: &[u8]| c.storage_with(data, wgpu::BufferUsages::COPY_DST);
        let state = c.storage(&m.state);
        let loads = c.storage(&m.loads);
        let props = c.storage(&m.props);
        let body = c.storage(&m.ints[n..]);
        let ints = c.storage(&m.ints);
        let built = c.storage(&vec![0.0f64; 3 * n]);
        let par = c.storage(&m.params);
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
        let pair_ij = c.storage(&m.pair_ij);
        let pair_history = c.storage(&m.pair_history);
        let pair_output = c.storage(&vec![0.0f64; 11 * pairs]);
        let new_ij = c.storage(&vec![EMPTY; 2 * pairs]);
        let new_pair_history = c.storage(&vec![0.0f64; 6 * pairs]);
        let rows = c.storage(&m.rows);
        let cands = c.storage(&m.cands);
        let wall_history = c.storage(&m.wall_history);
        let wall_output = c.storage(&vec![0.0f64; 10 * walls]);
        let new_cands = c.storage(&vec![EMPTY; 2 * walls]);
        let new_wall_history = c.storage(&vec![0.0f64; 6 * walls]);
        let table = c.storage(&m.table);
        let element_buf = storage_rw(bytemuck::cast_slice(&m.elements));
        let geoms = storage_rw(bytemuck::cast_slice(&m.geoms));
        let (element_track, geoms_track) = if moving {
            (c.storage(&m.element_track), c.storage(&m.geoms_track))
        } else {
            (c.storage(&[0.0f64]), c.storage(&[0.0f64]))
        };
        let forced = c.storage(&m.forced);
        let mut words = vec![0u32, 1, 0, 0, 0, worlds.len() as u32, 0, 0];
        words.extend(std::iter::repeat_n(EMPTY, worlds.len()));
        let ctrl = c.storage(&words);
        let dims = c.storage(&[
            n as u32,
            cap.pair as u32,
            cap.wall as u32,
            buckets as u32,
            cap.bucket as u32,
            geometries as u32,
            elements as u32,
            0,
        ]);
        let search = c.storage(&m.search);
        let bucket_count = c.storage(&vec![0u32; buckets]);
        let bucket_items = c.storage(&vec![0u32; buckets * cap.bucket]);
        let reverse_count = c.storage(&vec![0u32; n]);
        let geometry_loads = c.storage(&vec![0.0f64; 6 * geometries.max(1)]);

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
                    &props,
                    &par,
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
                    &par,
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
                    &par,
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
                    &props,
                    &par,
                ],
                n,
            ),
        ];
        let check = launch(
            &k.check,
            &[
                &state, &counts_n, &moved, &outside, &status, &ctrl, &search, &props, &par,
            ],
            n,
        );
        let begin = launch(&k.begin, &[&ctrl, &forced, &par], 0);
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
        // Once at the end: a world that stopped earlier kept its rows and wall output.
        let loads_launch = launch(
            &k.geometry_loads,
            &[&dims, &rows, &cands, &wall_output, &geometry_loads, &par],
            geometries.max(1),
        );

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
        let mut out = c.read_back(encoder, &[&ctrl]);
        check_overflow(&out[0])?;
        // A world is over once its steps are run or it failed; the run stops when all are.
        let over = |words: &[u32], done: usize| {
            worlds
                .iter()
                .enumerate()
                .all(|(w, world)| done >= world.steps as usize || words[8 + w] != EMPTY)
        };
        while done < steps {
            let chunk = (steps - done).min(CHUNK as usize);
            let mut encoder = c.device.create_command_encoder(&Default::default());
            for s in done..done + chunk {
                if moving {
                    let mut from = 16 * moving_rows * s;
                    for &(g, count) in &m.moving {
                        let first = m.geoms[8 * g + 1] as usize;
                        encoder.copy_buffer_to_buffer(
                            &element_track,
                            8 * from as u64,
                            &element_buf,
                            8 * (16 * first) as u64,
                            8 * 16 * count as u64,
                        );
                        from += 16 * count;
                    }
                    let row = 8 * geometries;
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
            out = c.read_back(encoder, &[&ctrl]);
            check_overflow(&out[0])?;
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
            if over(&words, done) {
                break;
            }
        }
        // The last step's kick, checked as every step's are: the worlds whose steps ran to the
        // end are still stepping, so `begin` marks them for the check alone.
        let mut encoder = c.device.create_command_encoder(&Default::default());
        encode(&mut encoder, &[&begin, &check, &loads_launch]);
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
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out[0]);
        let failed: Vec<Option<u64>> = (0..worlds.len())
            .map(|w| (words[8 + w] != EMPTY).then_some(words[8 + w] as u64))
            .collect();
        Ok(m.split(worlds, &out, words[4].saturating_sub(1) as u64, &failed))
    }
}
