//! The linear spring-dashpot law ("hooke", LIGGGHTS `model hooke`) through the contact-law seam:
//! a head-on impact rebounds with the restitution and lasts half the damped period.

mod common;

use common::*;
use dem::contact::{ContactLaw, ContactModel, Hooke, RollingModel};
use dem::particles::Particles;
use glam::DVec3;
use std::f64::consts::PI;

/// Rebound/incident speed ratio and contact duration of two equal spheres meeting head-on.
fn impact(restitution: f64, speed: f64, law: Hooke) -> (f64, f64, dem::contact::PairParams, f64) {
    let (r, density) = (0.005, 2500.0);
    let m = material("m", 1e8, 0.3, density);
    let t = table(m.clone(), m, interaction(restitution, 0.0, 0.0));
    let params = *t.pair(0, 0);
    let mut p = Particles::default();
    p.push(
        DVec3::new(-r - 1e-7, 0.0, 0.0),
        DVec3::X * speed,
        r,
        density,
        0,
    );
    p.push(
        DVec3::new(r + 1e-7, 0.0, 0.0),
        -DVec3::X * speed,
        r,
        density,
        0,
    );
    let m_eff = 0.5 * p.mass[0];
    let dt = 2e-8;
    let mut sim = simulation(
        p,
        t,
        vec![],
        dt,
        DVec3::ZERO,
        RollingModel::ConstantDirectionalTorque,
    );
    sim.params.contact_model = ContactModel::Hooke(law);
    let mut steps_in_contact = 0u64;
    for _ in 0..200_000 {
        sim.step().unwrap();
        let x = &sim.particles.position;
        if 2.0 * r - (x[0] - x[1]).length() > 0.0 {
            steps_in_contact += 1;
        } else if steps_in_contact > 0 {
            break;
        }
    }
    let rebound = (sim.particles.velocity[1].x - sim.particles.velocity[0].x) / (2.0 * speed);
    (rebound, steps_in_contact as f64 * dt, params, m_eff)
}

#[test]
fn hooke_head_on_impact_rebounds_with_the_restitution_in_half_the_damped_period() {
    let law = Hooke {
        characteristic_velocity: 2.0,
    };
    for e in [0.2, 0.5, 0.9] {
        let (ratio, duration, p, m_eff) = impact(e, 1.0, law);
        // zeta = -ln e / sqrt(ln^2 e + pi^2); t_c = pi / (omega_0 sqrt(1 - zeta^2)).
        let zeta = -e.ln() / (e.ln().powi(2) + PI * PI).sqrt();
        let r_eff = 0.0025;
        let k = law.stiffness(&p, m_eff, r_eff);
        let t_c = PI / ((k / m_eff).sqrt() * (1.0 - zeta * zeta).sqrt());
        eprintln!(
            "hooke e = {e}: rebound {ratio:.5}, contact {duration:.4e} s (analytic {t_c:.4e} s)"
        );
        assert!(rel_err(ratio, e) < 0.005, "e = {e}: rebound ratio {ratio}");
        assert!(
            rel_err(duration, t_c) < 0.005,
            "e = {e}: contact {duration}, want {t_c}"
        );
        assert!(rel_err(law.collision_time(&p, m_eff, r_eff, 1.0), t_c) < 1e-12);
    }
}

#[test]
fn hooke_stiffness_matches_liggghts_and_does_not_depend_on_impact_speed() {
    let law = Hooke::default();
    let m = material("m", 1e8, 0.3, 2500.0);
    let t = table(m.clone(), m, interaction(0.5, 0.0, 0.0));
    let p = *t.pair(0, 0);
    let (m_eff, r_eff) = (6.5e-4f64, 0.0025f64);
    // k_n = 16/15 sqrt(R*) Y* (15 m* v_c^2 / (16 sqrt(R*) Y*))^(1/5), Y* = E / (2 (1 - nu^2)).
    let y: f64 = 1e8 / (2.0 * (1.0 - 0.09));
    let want =
        16.0 / 15.0 * r_eff.sqrt() * y * (15.0 * m_eff / (16.0 * r_eff.sqrt() * y)).powf(0.2);
    assert!(rel_err(law.stiffness(&p, m_eff, r_eff), want) < 1e-12);
    // Linear: the contact lasts as long at 0.2 m/s as at 2 m/s (Hertz contacts would not).
    let (_, slow, _, _) = impact(0.5, 0.2, law);
    let (_, fast, _, _) = impact(0.5, 2.0, law);
    assert!(rel_err(slow, fast) < 0.005, "{slow} vs {fast}");
}

#[test]
fn contact_models_are_found_by_name() {
    assert_eq!(ContactModel::NAMES, &["hertz_mindlin", "hooke"]);
    let mut hooke = ContactModel::from_name("hooke").unwrap();
    assert_eq!(hooke.name(), "hooke");
    hooke.set_parameter("characteristic_velocity", 3.0).unwrap();
    assert_eq!(
        hooke,
        ContactModel::Hooke(Hooke {
            characteristic_velocity: 3.0
        })
    );
    assert!(hooke
        .set_parameter("characteristic_velocity", -1.0)
        .unwrap_err()
        .contains("expected a speed > 0"));
    assert!(ContactModel::from_name("walton").is_none());
    assert!(!hooke.cohesive());
    assert!(ContactModel::default().cohesive());
}

const SCENE: &str = r#"
[simulation]
steps = 10
contact_model = "hooke"
contact_parameters = { characteristic_velocity = 2.5 }

[[material]]
name = "grain"
density = 1200
poisson_ratio = 0.3
shear_modulus = 1e7

[[interaction]]
materials = ["grain", "grain"]
restitution = 0.4
static_friction = 0.5
rolling_friction = 0.1

[[particles]]
material = "grain"
size = { type = "fixed", radius = 0.002 }
region = { type = "box", min = [0.0, 0.0, 0.0], max = [0.02, 0.02, 0.02] }
fill = { type = "lattice", lattice = "sc", spacing = 0.005 }
"#;

fn load(text: &str) -> Result<dem::scene::Scene, String> {
    dem::scene::Scene::from_toml(text, "scene.toml", std::path::Path::new("."))
        .map_err(|e| e.to_string())
}

fn load_err(text: &str) -> String {
    match load(text) {
        Ok(_) => panic!("accepted"),
        Err(e) => e,
    }
}

#[test]
fn a_scene_chooses_hooke_and_sets_its_parameters() {
    let scene = load(SCENE).unwrap();
    assert_eq!(
        scene.simulation.params.contact_model,
        ContactModel::Hooke(Hooke {
            characteristic_velocity: 2.5
        })
    );
    let e = load_err(&SCENE.replace("characteristic_velocity = 2.5", "speed = 2.5"));
    assert_eq!(
        e,
        "scene.toml: simulation.contact_parameters.speed: hooke takes no parameter \"speed\" (expected characteristic_velocity)"
    );
    let e = load_err(&SCENE.replace(
        "rolling_friction = 0.1",
        "rolling_friction = 0.1\nsurface_energy = 0.2",
    ));
    assert!(
        e.starts_with(
            "scene.toml: interaction[0].surface_energy: the hooke contact model has no cohesion"
        ),
        "{e}"
    );
    let e = load_err(&SCENE.replace("\"hooke\"", "\"walton\""));
    assert_eq!(
        e,
        "scene.toml: simulation.contact_model: unknown model \"walton\" (expected one of: hertz_mindlin, hooke)"
    );
}
