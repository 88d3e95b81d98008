//! The shared harness on one bead and a plate: settling until quiet (and its cap), moving a
//! geometry by name, recording its force against its displacement, progress reports, and the
//! step budget.

use dem::fill::{FillRegion, Lattice, SizeDistribution};
use dem::scene::{
    GroupParticles, InteractionDescription, MaterialDescription, ParticleGroup, ParticleShape,
    Placement, Scene, SceneDescription, Stiffness,
};
use dem::Simulation;
use glam::DVec3;
use virtual_tests::harness::{self, ForceRecorder, Quiet};
use virtual_tests::{Run, TestFile};

const R: f64 = 0.002;
const DENSITY: f64 = 1200.0;
const G_BEAD: f64 = 5e6;
const NU: f64 = 0.3;

/// One bead of radius R, centre 1 mm above a steel plate whose top is at z = 0.
fn bead_on_plate() -> Simulation {
    let material = |name: &str, density: f64, shear: f64| MaterialDescription {
        name: name.into(),
        density,
        poisson_ratio: NU,
        stiffness: Stiffness::ShearModulus(shear),
    };
    let interaction = |other: &str| InteractionDescription {
        materials: ["bead".into(), other.into()],
        restitution: 0.5,
        static_friction: 0.5,
        rolling_friction: 0.1,
        surface_energy: 0.0,
    };
    let mut d = SceneDescription::new(dem::scene::RunLength::Steps(1));
    d.simulation = harness::simulation(20.0, (DVec3::splat(-0.1), DVec3::splat(0.1)));
    d.materials = vec![
        material("bead", DENSITY, G_BEAD),
        material("steel", 7850.0, 7e10),
    ];
    d.interactions = vec![interaction("bead"), interaction("steel")];
    d.geometries = vec![harness::plate("steel", 0.05, 0.05, 0.0)];
    // A lattice anchored at the region's corner holds exactly this one site.
    let centre = DVec3::new(0.0, 0.0, R + 0.001);
    d.particles = vec![ParticleGroup {
        particles: GroupParticles::Inline {
            material: "bead".into(),
            shape: ParticleShape::Sphere,
            size: SizeDistribution::Fixed { radius: R },
        },
        placement: Placement::Lattice {
            region: FillRegion::Box {
                min: centre,
                max: centre + DVec3::splat(1e-4),
            },
            lattice: Lattice::SimpleCubic,
            spacing: None,
            origin: None,
            seed: None,
        },
        velocity: DVec3::ZERO,
    }];
    let sim = Scene::from_description(&d, "scene").unwrap().simulation;
    assert_eq!(sim.particles.len(), 1);
    sim
}

fn weight() -> f64 {
    DENSITY * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3) * 9.81
}

/// Hertz: the overlap under the bead's weight, w = 4/3 E* sqrt(R) d^1.5, steel as good as rigid.
fn resting_overlap() -> f64 {
    let e_bead = 2.0 * G_BEAD * (1.0 + NU);
    let e_steel = 2.0 * 7e10 * (1.0 + NU);
    let e_star = 1.0 / ((1.0 - NU * NU) / e_bead + (1.0 - NU * NU) / e_steel);
    (weight() / (4.0 / 3.0 * e_star * R.sqrt())).powf(2.0 / 3.0)
}

#[test]
fn settling_stops_when_quiet_and_at_its_cap() {
    let mut sim = bead_on_plate();
    let mut reports = Vec::new();
    let mut progress = |phase: &str, t: f64| {
        reports.push((phase.to_string(), t));
        Ok(())
    };
    let mut run = Run::new(1, None, &mut progress);
    let quiet = Quiet {
        rms_speed: 1e-5,
        min_time: 0.05,
        max_time: 2.0,
        check_every: 0.01,
        wait_for_factories: false,
    };
    assert!(harness::settle(&mut sim, &quiet, "settle", &mut run).unwrap());
    let t = sim.time;
    assert!(t > 0.05 && t < 2.0, "{t}");
    assert!(harness::rms_speed(&sim) < 1e-5);
    // It rests on the plate at the Hertz overlap of its weight (about 0.6 um).
    let overlap = R - sim.particles.position[0].z;
    let want = resting_overlap();
    assert!(
        (overlap / want - 1.0).abs() < 0.03,
        "{overlap:e} vs {want:e}"
    );
    assert!(reports.iter().all(|r| r.0 == "settle"));
    assert_eq!(reports.last().unwrap().1, t);

    // A bead still falling is not quiet; the phase ends at its cap.
    let mut sim = bead_on_plate();
    let capped = Quiet {
        max_time: 0.02,
        ..quiet
    };
    let mut progress = |_: &str, _: f64| Ok(());
    let mut run = Run::new(1, None, &mut progress);
    assert!(!harness::settle(&mut sim, &capped, "settle", &mut run).unwrap());
    let dt = sim.params.time_step;
    let chunk = (0.01 / dt).ceil() * dt;
    assert!(sim.time >= 0.02 && sim.time < 0.02 + chunk, "{}", sim.time);
}

#[test]
fn progress_is_reported_at_least_every_thousand_steps_and_stops_the_run() {
    let mut sim = bead_on_plate();
    let mut times = Vec::new();
    let mut progress = |_: &str, t: f64| {
        times.push(t);
        Ok(())
    };
    let mut run = Run::new(1, None, &mut progress);
    harness::advance(&mut sim, 2500, "fall", &mut run, None).unwrap();
    assert_eq!(sim.steps, 2500);
    assert_eq!(times.len(), 3);
    let dt = sim.params.time_step;
    assert!((times[0] - 1000.0 * dt).abs() < 1e-9 * dt * 1000.0);

    // A callback's error stops the run at once, with its message.
    let mut calls = 0;
    let mut stop = |_: &str, _: f64| {
        calls += 1;
        Err("stopped by the user".to_string())
    };
    let mut run = Run::new(1, None, &mut stop);
    let e = harness::advance(&mut sim, 5000, "fall", &mut run, None).unwrap_err();
    assert!(matches!(e, harness::Stop::Stopped(ref m) if m == "stopped by the user"));
    assert_eq!(sim.steps, 3500);
    assert_eq!(calls, 1);
}

#[test]
fn a_geometry_moves_by_name() {
    let mut sim = bead_on_plate();
    let e = harness::translate(&mut sim, "lid", DVec3::Z, 1.0).unwrap_err();
    assert_eq!(e, "no geometry named \"lid\" (the scene has: plate)");
    let (v, duration) = (0.01, 0.05);
    let end = harness::translate(&mut sim, "plate", DVec3::new(0.0, 0.0, v), duration).unwrap();
    assert_eq!(end, duration);
    let mut progress = |_: &str, _: f64| Ok(());
    let mut run = Run::new(1, None, &mut progress);
    let dt = sim.params.time_step;
    while sim.time < end + 10.0 * dt {
        harness::advance(&mut sim, 1, "lift", &mut run, None).unwrap();
    }
    // It moved v * duration, to within the one step the window may cut.
    let plate = &sim.geometries[harness::geometry(&sim, "plate").unwrap()];
    assert!(
        (plate.translation.z - v * duration).abs() <= v * dt * 1.001,
        "{}",
        plate.translation.z
    );
    assert_eq!(plate.translation.x, 0.0);
}

#[test]
fn the_force_recorder_gives_weight_against_displacement_every_n_steps() {
    let mut sim = bead_on_plate();
    let mut progress = |_: &str, _: f64| Ok(());
    let mut run = Run::new(1, None, &mut progress);
    let quiet = Quiet {
        rms_speed: 1e-5,
        min_time: 0.05,
        max_time: 2.0,
        check_every: 0.01,
        wait_for_factories: false,
    };
    assert!(harness::settle(&mut sim, &quiet, "settle", &mut run).unwrap());
    // Lift the plate slowly (so the bead's inertia adds nothing measurable) and record the push
    // of the bead on it along -z, and the plate's travel along -z.
    let v = 1e-5;
    harness::translate(&mut sim, "plate", DVec3::new(0.0, 0.0, v), 1.0).unwrap();
    let mut recorder = ForceRecorder::new(&sim, "plate", -DVec3::Z, 10).unwrap();
    let start = sim.steps;
    harness::advance(&mut sim, 205, "lift", &mut run, Some(&mut recorder)).unwrap();
    let (x, y) = recorder.samples();
    // The start, then every 10 steps: 20 more.
    assert_eq!(x.len(), 21);
    assert_eq!(y.len(), 21);
    let dt = sim.params.time_step;
    for (k, (&d, &f)) in x.iter().zip(y).enumerate() {
        // The first sample is at rest before the lift.
        assert!((f / weight() - 1.0).abs() < 0.01, "sample {k}: {f} N");
        let travelled = -v * dt * (10 * k) as f64;
        assert!(
            (d - travelled).abs() < 1e-3 * v * dt,
            "sample {k}: {d:e} vs {travelled:e}"
        );
    }
    assert_eq!(sim.steps - start, 205);
    let virtual_tests::Response::Curve {
        x_name,
        x_unit,
        y_name,
        y_unit,
        x: cx,
        ..
    } = recorder.curve()
    else {
        panic!("a curve")
    };
    assert_eq!(
        (
            x_name.as_str(),
            x_unit.as_str(),
            y_name.as_str(),
            y_unit.as_str()
        ),
        ("displacement", "m", "force", "N")
    );
    assert_eq!(cx.len(), 21);
}

#[test]
fn a_test_that_would_need_too_many_steps_is_refused_naming_the_longest_phase() {
    let file = TestFile::parse(
        "t.toml",
        "test = \"function\"\n[function]\nexpression = \"1\"\n",
    )
    .unwrap();
    let phases = [
        ("settle_max_time", "settling".to_string(), 2.0),
        ("lift_speed", "lifting 0.1 m at 1e-9 m/s".to_string(), 1e8),
    ];
    let e = harness::budget(&file, 2e-5, &phases).unwrap_err();
    assert_eq!(
        e,
        "t.toml: function.lift_speed: lifting 0.1 m at 1e-9 m/s takes 1.000e8 s of simulated time; \
         the test would need 5.000e12 time steps of 2.000e-5 s, more than the 1e9 a test run may take"
    );
    harness::budget(&file, 2e-5, &phases[..1]).unwrap();
    let nan = [("settle_max_time", "settling".to_string(), f64::NAN)];
    assert!(harness::budget(&file, 2e-5, &nan).is_err());
}
