//! Convex polyhedra in the engine (docs/physics.md, polyhedral particles): a cube resting on a
//! plane, a cube on an incline either side of its friction angle, the free rotation of a box, and
//! head-on impacts against the input restitution.

mod common;

use common::*;
use dem::clump::Bodies;
use dem::contact::RollingModel;
use dem::particles::Particles;
use dem::polyhedron::ConvexPolyhedron;
use dem::sim::Simulation;
use glam::{DQuat, DVec3};
use std::sync::Arc;

const H: f64 = 0.005; // half side of the cube
const DENSITY: f64 = 1000.0;
const DT: f64 = 1e-5;

fn cuboid(a: f64, b: f64, c: f64) -> Arc<ConvexPolyhedron> {
    let pts: Vec<DVec3> = (0..8)
        .map(|k| {
            DVec3::new(
                if k & 1 == 0 { -a } else { a },
                if k & 2 == 0 { -b } else { b },
                if k & 4 == 0 { -c } else { c },
            )
        })
        .collect();
    Arc::new(ConvexPolyhedron::from_points(&pts).unwrap().0)
}

/// One polyhedron per (shape, position, orientation, velocity), materials 0 (particles) and 1 (walls).
fn scene(
    items: &[(Arc<ConvexPolyhedron>, DVec3, DQuat, DVec3)],
    restitution: f64,
    friction: f64,
    gravity: DVec3,
    floor_too: bool,
) -> Simulation {
    let mut p = Particles::default();
    let mut bodies = Bodies::default();
    for (shape, x, q, v) in items {
        bodies.add_polyhedron(&mut p, shape, 1.0, DENSITY, 0, *x, *q, *v);
    }
    let geometries = if floor_too { vec![floor(1)] } else { vec![] };
    assemble(p, bodies, restitution, friction, gravity, geometries)
}

/// The simulation of particles and bodies already made, materials 0 (particles) and 1 (walls).
fn assemble(
    p: Particles,
    bodies: Bodies,
    restitution: f64,
    friction: f64,
    gravity: DVec3,
    geometries: Vec<dem::geometry::Geometry>,
) -> Simulation {
    let t = table(
        material("p", 1e7, 0.3, DENSITY),
        material("w", 1e7, 0.3, 7800.0),
        interaction(restitution, friction, 0.0),
    );
    let mut sim = simulation(
        p,
        t,
        geometries,
        DT,
        gravity,
        RollingModel::ConstantDirectionalTorque,
    )
    .with_bodies(bodies);
    sim.params.skin = 0.2 * H;
    sim
}

fn run(sim: &mut Simulation, seconds: f64) {
    let steps = (seconds / DT).round() as usize;
    for _ in 0..steps {
        sim.step().unwrap();
    }
}

#[test]
fn cube_rests_on_a_plane_with_its_weight_and_no_drift() {
    let cube = cuboid(H, H, H);
    let g = 9.81;
    let mut sim = scene(
        &[(
            cube.clone(),
            DVec3::new(0.0, 0.0, H),
            DQuat::IDENTITY,
            DVec3::ZERO,
        )],
        0.5,
        0.5,
        DVec3::new(0.0, 0.0, -g),
        true,
    );
    run(&mut sim, 0.3);
    let at_rest = sim.bodies.position[0];
    let weight = DENSITY * 8.0 * H * H * H * g;
    run(&mut sim, 0.7);
    let load = sim.geometries[0].load.force;
    let drift = (sim.bodies.position[0] - at_rest).length();
    let speed = sim.bodies.velocity[0].length();
    let spin = sim.bodies.rotation[0].angular_velocity().length();
    eprintln!(
        "cube on plane: load {:.6e} N against weight {weight:.6e} N (rel {:.2e}), drift {drift:.2e} m over 0.7 s, speed {speed:.2e} m/s, spin {spin:.2e} rad/s, sinks {:.3e} m",
        -load.z,
        rel_err(-load.z, weight),
        H - sim.bodies.position[0].z
    );
    assert!(rel_err(-load.z, weight) < 1e-6);
    assert!(load.x.abs() + load.y.abs() < 1e-9 * weight);
    assert!(drift < 1e-9, "{drift}");
    assert!(speed < 1e-7 && spin < 1e-5);
    // Flat punch: the face sinks by weight / (2 E* a), a = sqrt(A / pi).
    let e_star = 1.0 / (2.0 * (1.0 - 0.09) / 1e7);
    let a = (4.0 * H * H / std::f64::consts::PI).sqrt();
    let sink = H - sim.bodies.position[0].z;
    assert!(rel_err(sink, weight / (2.0 * e_star * a)) < 1e-3, "{sink}");
    // Upright: the orientation has not changed.
    assert!(
        sim.bodies.rotation[0]
            .orientation
            .angle_between(DQuat::IDENTITY)
            < 1e-6
    );
}

/// Distance slid along x in `seconds` on a plane tilted `angle` (gravity tilted instead).
fn slide(angle_deg: f64, friction: f64, seconds: f64) -> (f64, f64) {
    let g = 9.81;
    let th = angle_deg.to_radians();
    let gravity = DVec3::new(g * th.sin(), 0.0, -g * th.cos());
    let mut sim = scene(
        &[(
            cuboid(H, H, H),
            DVec3::new(0.0, 0.0, H),
            DQuat::IDENTITY,
            DVec3::ZERO,
        )],
        0.5,
        friction,
        gravity,
        true,
    );
    // Settle normal to the plane first with friction holding, then measure from there.
    run(&mut sim, 0.05);
    let x0 = sim.bodies.position[0].x;
    let v0 = sim.bodies.velocity[0].x;
    run(&mut sim, seconds);
    let x1 = sim.bodies.position[0].x;
    let v1 = sim.bodies.velocity[0].x;
    let _ = v0;
    (x1 - x0, v1)
}

#[test]
fn cube_on_an_incline_holds_below_and_slides_above_its_friction_angle() {
    let mu = 0.5;
    let friction_angle = mu_angle(mu);
    let (held, _) = slide(friction_angle - 2.0, mu, 0.3);
    let g = 9.81;
    let th = (friction_angle + 2.0).to_radians();
    let accel = g * (th.sin() - mu * th.cos());
    let t = 0.3;
    let (slid, v) = slide(friction_angle + 2.0, mu, t);
    eprintln!(
        "incline: {:.2} deg holds ({held:.2e} m in {t} s); {:.2} deg slides {slid:.4e} m, speed {v:.4e} m/s against a = {accel:.4} m/s^2",
        friction_angle - 2.0,
        friction_angle + 2.0
    );
    assert!(held.abs() < 1e-6, "{held}");
    // Sliding from nearly rest: speed grows at g (sin - mu cos) (the first 0.05 s settle adds a
    // small head start, so the speed change is compared).
    let (_, v_short) = slide(friction_angle + 2.0, mu, 0.1);
    let measured = (v - v_short) / (t - 0.1);
    assert!(rel_err(measured, accel) < 0.02, "{measured} vs {accel}");
}

fn mu_angle(mu: f64) -> f64 {
    mu.atan().to_degrees()
}

#[test]
fn free_rotation_of_a_box_conserves_energy_and_angular_momentum() {
    let shape = cuboid(0.015, 0.01, 0.005);
    let mut sim = scene(
        &[(
            shape,
            DVec3::ZERO,
            DQuat::IDENTITY,
            DVec3::new(0.01, 0.0, 0.0),
        )],
        0.5,
        0.5,
        DVec3::ZERO,
        false,
    );
    let i = sim.bodies.rotation[0].principal_inertia;
    // Near the intermediate axis: the tumbling case.
    sim.bodies.rotation[0].angular_momentum = DVec3::new(0.05 * i.x, 20.0 * i.y, 0.05 * i.z);
    let e0 = sim.kinetic_energy();
    let l0 = sim.bodies.rotation[0].angular_momentum;
    let mut largest = 0.0f64;
    for _ in 0..20 {
        run(&mut sim, 0.05);
        largest = largest.max(rel_err(sim.kinetic_energy(), e0));
    }
    let l1 = sim.bodies.rotation[0].angular_momentum;
    eprintln!(
        "free box: largest relative energy change {largest:.2e} over 1e5 steps, |dL|/|L| {:.2e}",
        (l1 - l0).length() / l0.length()
    );
    assert!(largest < 1e-3);
    assert!((l1 - l0).length() < 1e-12 * l0.length());
}

/// Separation speed over approach speed of two equal bodies meeting head on along x.
fn restitution(shape: &Arc<ConvexPolyhedron>, q: DQuat, reach: f64, e: f64) -> f64 {
    let v = 0.2;
    let gap = 0.2 * reach;
    let mut sim = scene(
        &[
            (
                shape.clone(),
                DVec3::new(-reach - gap, 0.0, 0.0),
                q,
                DVec3::new(v, 0.0, 0.0),
            ),
            (
                shape.clone(),
                DVec3::new(reach + gap, 0.0, 0.0),
                DQuat::from_rotation_z(std::f64::consts::PI) * q,
                DVec3::new(-v, 0.0, 0.0),
            ),
        ],
        e,
        0.5,
        DVec3::ZERO,
        false,
    );
    run(&mut sim, 2.0 * gap / v + 0.01);
    let after = sim.bodies.velocity[1].x - sim.bodies.velocity[0].x;
    after / (2.0 * v)
}

#[test]
fn head_on_impacts_give_the_input_restitution() {
    let cube = cuboid(H, H, H);
    for e in [0.3, 0.5, 0.8] {
        let got = restitution(&cube, DQuat::IDENTITY, H, e);
        eprintln!("face on face: input restitution {e}, measured {got:.4}");
        assert!((got - e).abs() < 0.05, "{e}: {got}");
    }
    // Vertex on vertex: each cube's body diagonal along x, so the contact grows as a double
    // pyramid (force ~ overlap^2 rather than linear).
    let q = DQuat::from_rotation_arc(DVec3::ONE.normalize(), DVec3::X);
    let mut vertex = Vec::new();
    for e in [0.3, 0.5, 0.8] {
        let got = restitution(&cube, q, 3f64.sqrt() * H, e);
        eprintln!("vertex on vertex: input restitution {e}, measured {got:.4}");
        vertex.push(got);
    }
    // The Hertz-Mindlin damping is tuned for force ~ overlap^1.5; a pointed contact is stiffer at
    // depth and its restitution comes out lower: measured 0.194, 0.402 and 0.749 for 0.3, 0.5, 0.8.
    for (got, e) in vertex.iter().zip([0.3, 0.5, 0.8]) {
        assert!(*got < e && *got > e - 0.15, "{e}: {got}");
    }
}

#[test]
fn cube_on_a_triangle_mesh_and_in_a_box_carries_its_weight_once() {
    use dem::geometry::{Element, Geometry};
    // A square of two triangles under the cube, split along the diagonal the cube sits across.
    let s = 0.02;
    let (a, b, c, d) = (
        DVec3::new(-s, -s, 0.0),
        DVec3::new(s, -s, 0.0),
        DVec3::new(s, s, 0.0),
        DVec3::new(-s, s, 0.0),
    );
    let mesh = Geometry::new(
        "mesh",
        1,
        vec![
            Element::Triangle { a, b, c },
            Element::Triangle { a, b: c, c: d },
        ],
    );
    let g = 9.81;
    let mut sim = scene(
        &[(
            cuboid(H, H, H),
            DVec3::new(0.002, 0.001, H),
            DQuat::IDENTITY,
            DVec3::ZERO,
        )],
        0.5,
        0.5,
        DVec3::new(0.0, 0.0, -g),
        false,
    );
    sim.geometries.push(mesh);
    run(&mut sim, 0.3);
    let weight = DENSITY * 8.0 * H * H * H * g;
    let load = sim.geometries[0].load.force;
    // The two triangles' pieces are one contact: the cube sinks as on a plane (flat punch).
    let e_star = 1.0 / (2.0 * (1.0 - 0.09) / 1e7);
    let a = (4.0 * H * H / std::f64::consts::PI).sqrt();
    let sink = H - sim.bodies.position[0].z;
    eprintln!(
        "cube on two triangles: load {:.6e} N against weight {weight:.6e} N, sinks {sink:.4e} m against {:.4e} m",
        -load.z,
        weight / (2.0 * e_star * a)
    );
    assert!(rel_err(-load.z, weight) < 1e-6);
    assert!(rel_err(sink, weight / (2.0 * e_star * a)) < 1e-3, "{sink}");
    assert!(sim.bodies.velocity[0].length() < 1e-7);
    // Pushed into the corner of an open box of rectangles (frictionless): floor and two walls.
    let walls = Geometry::new(
        "box",
        1,
        dem::geometry::shapes::box_walls(
            DVec3::new(-0.02, -0.02, 0.0),
            DVec3::new(0.02, 0.02, 0.04),
            &["+z".to_string()],
        ),
    );
    let mut sim = scene(
        &[(
            cuboid(H, H, H),
            DVec3::new(-0.014, -0.014, H + 0.001),
            DQuat::IDENTITY,
            DVec3::ZERO,
        )],
        0.5,
        0.0,
        DVec3::new(-1.0, -1.0, -g),
        false,
    );
    sim.geometries.push(walls);
    run(&mut sim, 0.3);
    let load = sim.geometries[0].load.force;
    let m = DENSITY * 8.0 * H * H * H;
    eprintln!(
        "cube in a box corner: load {load} N against {:?}",
        DVec3::new(-m, -m, -m * g)
    );
    assert!((load - DVec3::new(-m, -m, -m * g)).length() < 1e-6 * m * g);
    let x = sim.bodies.position[0];
    assert!(
        (x - DVec3::new(-0.015, -0.015, H)).abs().max_element() < 1e-5,
        "{x}"
    );
}

#[test]
fn a_sphere_rests_on_a_polyhedron() {
    // A 2 mm sphere on top of a cube lying on the floor: the floor carries both weights, the
    // sphere sits on the cube's top face at the Hertz overlap.
    let g = 9.81;
    let cube = cuboid(H, H, H);
    let mut sim = {
        let mut p = Particles::default();
        let mut bodies = Bodies::default();
        bodies.add_polyhedron(
            &mut p,
            &cube,
            1.0,
            DENSITY,
            0,
            DVec3::new(0.0, 0.0, H),
            DQuat::IDENTITY,
            DVec3::ZERO,
        );
        p.push(
            DVec3::new(0.001, 0.0, 2.0 * H + 0.002),
            DVec3::ZERO,
            0.002,
            DENSITY,
            0,
        );
        assemble(
            p,
            bodies,
            0.5,
            0.5,
            DVec3::new(0.0, 0.0, -g),
            vec![floor(1)],
        )
    };
    run(&mut sim, 0.4);
    let sphere_mass = DENSITY * 4.0 / 3.0 * std::f64::consts::PI * 0.002f64.powi(3);
    let weight = (DENSITY * 8.0 * H * H * H + sphere_mass) * g;
    let load = sim.geometries[0].load.force;
    let sphere = sim.particles.position[sim.particles.len() - 1];
    let e_star = 1.0 / (2.0 * (1.0 - 0.09) / 1e7);
    let want = resting_overlap(sphere_mass * g, e_star, 0.002);
    let top = sim.bodies.position[0].z + H;
    let overlap = 0.002 - (sphere.z - top);
    eprintln!(
        "sphere on cube: floor load {:.6e} N against {weight:.6e} N; overlap {overlap:.4e} m against Hertz {want:.4e} m",
        -load.z
    );
    assert!(rel_err(-load.z, weight) < 1e-6);
    assert!(rel_err(overlap, want) < 1e-3);
    assert!((sphere.x - 0.001).abs() < 1e-6 && sphere.y.abs() < 1e-9);
}

/// An ASCII STL of the prism of a polygon (counter-clockwise, star-shaped from its first vertex)
/// from z = 0 to `h`, in millimetres.
fn prism_stl(polygon: &[(f64, f64)], h: f64) -> String {
    let mut tris: Vec<[DVec3; 3]> = Vec::new();
    let p = |k: usize, z: f64| DVec3::new(polygon[k].0, polygon[k].1, z);
    let n = polygon.len();
    for k in 1..n - 1 {
        tris.push([p(0, h), p(k, h), p(k + 1, h)]);
        tris.push([p(0, 0.0), p(k + 1, 0.0), p(k, 0.0)]);
    }
    for k in 0..n {
        let j = (k + 1) % n;
        tris.push([p(k, 0.0), p(j, 0.0), p(j, h)]);
        tris.push([p(k, 0.0), p(j, h), p(k, h)]);
    }
    let mut s = String::from("solid prism\n");
    for t in tris {
        let nn = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        s += &format!("facet normal {} {} {}\nouter loop\n", nn.x, nn.y, nn.z);
        for v in t {
            s += &format!("vertex {} {} {}\n", v.x, v.y, v.z);
        }
        s += "endloop\nendfacet\n";
    }
    s + "endsolid prism\n"
}

#[test]
fn polyhedra_from_stl_files_take_the_convex_hull() {
    let dir = std::env::temp_dir().join(format!("demcal-poly-stl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A 6 x 4 x 3 mm box, and an L of 2 x 2 mm with a 1 mm notch (area 3 of its hull's 3.5), 3 mm high.
    std::fs::write(
        dir.join("box.stl"),
        prism_stl(&[(0.0, 0.0), (6.0, 0.0), (6.0, 4.0), (0.0, 4.0)], 3.0),
    )
    .unwrap();
    std::fs::write(
        dir.join("ell.stl"),
        prism_stl(
            &[
                (1.0, 1.0),
                (1.0, 2.0),
                (0.0, 2.0),
                (0.0, 0.0),
                (2.0, 0.0),
                (2.0, 1.0),
            ],
            3.0,
        ),
    )
    .unwrap();
    let scene = |file: &str| {
        format!(
            r#"
[simulation]
duration = 0.001
[[material]]
name = "seed"
density = 1100
poisson_ratio = 0.3
shear_modulus = 1e7
[[interaction]]
materials = ["seed", "seed"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.0
[[particles]]
material = "seed"
shape = {{ type = "polyhedron", file = "{file}", file_scale = 0.001 }}
region = {{ type = "box", min = [0, 0, 0], max = [0.05, 0.05, 0.05] }}
fill = {{ type = "random", count = 10, seed = 1 }}
"#
        )
    };
    let load = |file: &str| dem::scene::Scene::from_toml(&scene(file), "s.toml", &dir);
    let boxed = load("box.stl").expect("box loads");
    let v = boxed
        .simulation
        .bodies
        .polyhedra
        .shape_of(0)
        .unwrap()
        .volume;
    assert!((v / (6e-3 * 4e-3 * 3e-3) - 1.0).abs() < 1e-9, "{v}");
    assert!(boxed.warnings.is_empty(), "{:?}", boxed.warnings);
    let ell = load("ell.stl").expect("L loads");
    let v = ell.simulation.bodies.polyhedra.shape_of(0).unwrap().volume;
    assert!((v / (3.5e-6 * 3e-3) - 1.0).abs() < 1e-9, "{v}");
    let warned = ell
        .warnings
        .iter()
        .find(|w| w.contains("not convex"))
        .unwrap();
    assert!(warned.contains("85.7 %"), "{warned}");
    // An open mesh (the box without its top) has no volume to compare with its hull: refused.
    let open: String = prism_stl(&[(0.0, 0.0), (6.0, 0.0), (6.0, 4.0), (0.0, 4.0)], 3.0)
        .split("facet normal")
        .enumerate()
        .filter(|(k, _)| *k != 1 && *k != 3)
        .map(|(k, part)| {
            if k == 0 {
                part.to_string()
            } else {
                format!("facet normal{part}")
            }
        })
        .collect();
    std::fs::write(dir.join("open.stl"), open).unwrap();
    let e = load("open.stl").err().expect("refused").to_string();
    assert!(
        e.contains("particles[0].shape.file") && e.contains("not closed"),
        "{e}"
    );
    let e = load("missing.stl").err().expect("refused").to_string();
    assert!(
        e.contains("particles[0].shape.file") && e.contains("does not exist"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cube_on_the_crest_of_a_cylinder_and_a_scaled_cube() {
    use dem::geometry::{Element, Geometry};
    // A horizontal shell of radius 20 mm along x; a cube set on its crest rests there, carried
    // by the shell with no sideways push.
    let r = 0.02;
    let shell = Geometry::new(
        "shell",
        1,
        vec![Element::CylinderShell {
            base: DVec3::new(-0.03, 0.0, 0.0),
            axis: DVec3::X,
            radius: r,
            length: 0.06,
        }],
    );
    let g = 9.81;
    let mut sim = scene(
        &[(
            cuboid(H, H, H),
            DVec3::new(0.0, 0.0, r + H),
            DQuat::IDENTITY,
            DVec3::ZERO,
        )],
        0.5,
        0.5,
        DVec3::new(0.0, 0.0, -g),
        false,
    );
    sim.geometries.push(shell);
    run(&mut sim, 0.2);
    let weight = DENSITY * 8.0 * H * H * H * g;
    let load = sim.geometries[0].load.force;
    let x = sim.bodies.position[0];
    eprintln!("cube on a cylinder's crest: load {load} N, centre {x}");
    assert!(rel_err(-load.z, weight) < 1e-6);
    assert!(load.y.abs() < 1e-9 * weight && x.y.abs() < 1e-9);
    assert!((x.z - (r + H)).abs() < 1e-5, "{x}");

    // The same cube drawn at scale 2 on a plane: 8 times the mass, twice the bounding radius,
    // and it rests on its face.
    let cube = cuboid(H, H, H);
    let mut p = Particles::default();
    let mut bodies = Bodies::default();
    bodies.add_polyhedron(
        &mut p,
        &cube,
        2.0,
        DENSITY,
        0,
        DVec3::new(0.0, 0.0, 2.0 * H),
        DQuat::IDENTITY,
        DVec3::ZERO,
    );
    bodies.add_polyhedron(
        &mut p,
        &cube,
        1.0,
        DENSITY,
        0,
        DVec3::new(0.05, 0.0, H),
        DQuat::IDENTITY,
        DVec3::ZERO,
    );
    assert_eq!(bodies.polyhedra.shapes.len(), 1, "one shape at two scales");
    let m1 = DENSITY * 8.0 * H * H * H;
    assert!(rel_err(bodies.mass[0], 8.0 * m1) < 1e-12);
    assert!(rel_err(p.radius[0], 2.0 * p.radius[1]) < 1e-12);
    let mut sim = assemble(
        p,
        bodies,
        0.5,
        0.5,
        DVec3::new(0.0, 0.0, -g),
        vec![floor(1)],
    );
    run(&mut sim, 0.3);
    let load = sim.geometries[0].load.force;
    assert!(rel_err(-load.z, 9.0 * m1 * g) < 1e-6, "{load}");
    let e_star = 1.0 / (2.0 * (1.0 - 0.09) / 1e7);
    let a = (16.0 * H * H / std::f64::consts::PI).sqrt();
    let sink = 2.0 * H - sim.bodies.position[0].z;
    assert!(
        rel_err(sink, 8.0 * m1 * g / (2.0 * e_star * a)) < 1e-3,
        "{sink}"
    );
}

#[test]
fn a_cube_inside_another_is_pushed_out() {
    // A small cube wholly inside a large one has no contact surface; it is pushed along the line
    // of centres instead of staying inside.
    let mut sim = scene(
        &[
            (
                cuboid(4.0 * H, 4.0 * H, 4.0 * H),
                DVec3::ZERO,
                DQuat::IDENTITY,
                DVec3::ZERO,
            ),
            (
                cuboid(0.5 * H, 0.5 * H, 0.5 * H),
                DVec3::new(H, 0.0, 0.0),
                DQuat::IDENTITY,
                DVec3::ZERO,
            ),
        ],
        0.5,
        0.5,
        DVec3::ZERO,
        false,
    );
    run(&mut sim, 0.05);
    let (big, small) = (sim.bodies.position[0], sim.bodies.position[1]);
    eprintln!("cube inside a cube: small at {small}, large at {big}");
    assert!(small.x - big.x > 4.5 * H, "{small} {big}");
    assert!(small.y.abs() < 1e-9 && small.z.abs() < 1e-9);
}
