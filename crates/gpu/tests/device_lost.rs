//! A device lost in the middle of a simulation (a driver reset; here `GpuContext::lose_device`,
//! which destroys it) is an error with a message, not a panic: the simulation goes on on the CPU
//! from the state the host holds, and later simulations that ask for "gpu" get the CPU with the
//! reason. Run on Mesa's lavapipe in CI, like the agreement tests.

use std::sync::Arc;

use dem::sim::Simulation;
use dem_gpu::{GpuContext, GpuStages};

mod common;
use common::{gpu, heap, Heap};

fn small_heap() -> Simulation {
    heap(&Heap {
        spheres: 60,
        ..Heap::default()
    })
}

fn largest_position_difference(a: &Simulation, b: &Simulation) -> f64 {
    let at = |s: &Simulation, id: usize| {
        let k = s
            .particles
            .id
            .iter()
            .position(|&x| x as usize == id)
            .unwrap();
        s.particles.position[k]
    };
    (0..a.particles.len())
        .map(|id| (at(a, id) - at(b, id)).length())
        .fold(0.0, f64::max)
}

#[test]
fn a_simulation_goes_on_on_the_cpu_when_its_device_is_lost() {
    // `gpu()` says whether this machine has a device at all (and fails under DEMCAL_REQUIRE_GPU
    // when it has none); the device lost here is a context of this test's own.
    if gpu().is_none() {
        return;
    }
    let ctx = Arc::new(GpuContext::new().unwrap());
    let stages = GpuStages::with_context(ctx.clone());
    let mut cpu = small_heap();
    let mut on_gpu = small_heap().with_backend(Box::new(stages.clone()));
    cpu.run(500).unwrap();
    on_gpu.run(500).unwrap();
    let (segments, _, _) = stages.segments();
    assert!(segments > 0, "the first steps ran on the device");
    assert_eq!(ctx.failure(), None);

    ctx.lose_device();
    cpu.run(1500).unwrap();
    // No panic: every stage after the loss runs on the CPU.
    on_gpu.run(1500).unwrap();
    let failure = ctx.failure().expect("the loss is recorded");
    eprintln!("recorded: {failure}");
    assert!(
        failure.contains("lost") || failure.contains("failed"),
        "{failure}"
    );
    assert!(
        failure.contains(ctx.adapter().split(" (").next().unwrap()),
        "{failure}"
    );
    assert!(stages.handed_to_cpu() > 0, "the stages went to the CPU");
    // The device's 500 steps agree with the CPU's to round-off, and the rest is the CPU's own.
    let dx = largest_position_difference(&cpu, &on_gpu);
    eprintln!("largest position difference after the loss: {dx:e} m");
    assert!(dx < 1e-9, "positions differ by {dx:e} m");
    assert!(on_gpu
        .particles
        .position
        .iter()
        .all(|x| x.is_finite() && x.z > -0.001));
    // The heap kept falling into the cylinder on the CPU: gravity still acts.
    let lowest = on_gpu
        .particles
        .position
        .iter()
        .map(|x| x.z)
        .fold(f64::INFINITY, f64::min);
    assert!(lowest < 0.002, "lowest sphere at {lowest} m");
}

#[test]
fn after_a_loss_new_simulations_get_the_cpu_with_the_reason() {
    if gpu().is_none() {
        return;
    }
    dem_gpu::register();
    assert_eq!(dem::sim::resolve_backend("gpu").unwrap(), ("gpu", None));
    let mut sim = small_heap();
    let said = sim.choose_backend("gpu");
    assert_eq!(sim.backend_name(), "gpu", "{said:?}");
    sim.run(200).unwrap();
    dem_gpu::shared_context().unwrap().lose_device();
    sim.run(200).unwrap();
    let (chosen, why) = dem::sim::resolve_backend("gpu").unwrap();
    assert_eq!(chosen, "cpu");
    let why = why.expect("a reason");
    assert!(why.ends_with("; running on the CPU"), "{why}");
    assert!(why.contains("lost") || why.contains("failed"), "{why}");
    let mut next = small_heap();
    let said = next.choose_backend("gpu");
    assert_eq!(next.backend_name(), "cpu");
    assert!(
        said.iter().any(|s| s.contains("running on the CPU")),
        "{said:?}"
    );
    next.run(100).unwrap();
}
