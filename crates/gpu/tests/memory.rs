//! A batch packed to the device's memory: worlds that together need more than the context's
//! memory budget run in several smaller batches, each world with the bits it gets in one batch.
//! (A test binary of its own: the batch counts it reads are the process's.)

use std::sync::Arc;

use dem::sim::Simulation;
use dem_gpu::batch::batch_stats;
use dem_gpu::{GpuContext, GpuStages};
use glam::DVec3;

mod common;
use common::{gpu, heap, together, Heap};

/// Six heaps of different sizes and seeds, each 600 steps (the lift starts at 0.02 s).
fn heaps() -> Vec<Heap> {
    [(1, 60), (2, 140), (3, 90), (4, 120), (5, 70), (6, 100)]
        .into_iter()
        .map(|(seed, spheres)| Heap {
            seed,
            spheres,
            ..Heap::default()
        })
        .collect()
}

/// The bits of a heap's end state after its steps on `stages`.
fn run(h: &Heap, stages: GpuStages) -> Vec<u64> {
    let mut sim: Simulation = heap(h).with_backend(Box::new(stages.clone()));
    sim.run(600).unwrap();
    let (segments, declined, _) = stages.segments();
    assert!(
        segments > 0 && declined == 0,
        "{segments} segments, {declined} declined"
    );
    let p = &sim.particles;
    [&p.position, &p.velocity, &p.angular_velocity, &p.force]
        .iter()
        .flat_map(|v| {
            v.iter()
                .flat_map(|x: &DVec3| x.to_array().map(f64::to_bits))
        })
        .collect()
}

#[test]
fn a_batch_larger_than_the_memory_budget_runs_in_smaller_batches_with_the_same_bits() {
    let Some(ctx) = gpu() else {
        return;
    };
    let cases = heaps();
    // All six in one batch, with the device's own budget.
    let before = batch_stats();
    let whole = together(&ctx, &cases, run);
    let after = batch_stats();
    assert!(
        after.batches > before.batches && after.largest == cases.len() && after.packed == 0,
        "the six did not run as one batch: {before:?} -> {after:?}"
    );
    let needed = after.most_bytes;
    assert!(needed > 0 && needed < ctx.memory_budget(), "{after:?}");

    // Room for about two of them at a time: the batch is packed (a try over the room does not
    // run, `resident::run`).
    let room = needed * 2 / 5;
    let small = Arc::new(
        GpuContext::new()
            .expect("a second context on the same device")
            .with_memory_budget(room),
    );
    let packed = together(&small, &cases, run);
    let later = batch_stats();
    eprintln!(
        "one batch of six took {needed} bytes; with room for {room}: {} more batches of {} worlds, packed {} times",
        later.batches - after.batches,
        later.worlds - after.worlds,
        later.packed - after.packed
    );
    assert!(later.packed > after.packed, "{after:?} -> {later:?}");
    // Groups of two or three share launches (how many depends on when the threads arrive: a
    // straggler runs in the next batch).
    assert!(
        later.batches > after.batches,
        "the packed groups did not run as batches of several worlds: {after:?} -> {later:?}"
    );
    assert_eq!(ctx.failure(), None);
    assert_eq!(small.failure(), None);
    for (k, (a, b)) in whole.iter().zip(&packed).enumerate() {
        assert!(a == b, "heap {k}: packed differs from the whole batch");
    }
}
