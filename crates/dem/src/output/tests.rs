//! Snapshots read back: the XML header and the appended block parsed here, by hand, as a reader
//! that knows only the VTK file format would.

use super::*;
use crate::scene::Scene;
use std::path::PathBuf;

/// A few spheres and rods in a box on a floor plane, with a cylinder rising through them.
const SCENE: &str = r#"
[simulation]
duration = 0.01
time_step_percent = 20
domain = { min = [-0.05, -0.05, -0.01], max = [0.05, 0.05, 0.1] }

[[material]]
name = "grain"
density = 1200
poisson_ratio = 0.3
shear_modulus = 1e7

[[interaction]]
materials = ["grain", "grain"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.05

[[geometry]]
name = "floor"
type = "plane"
material = "grain"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[geometry]]
name = "bin"
type = "box"
material = "grain"
min = [-0.03, -0.03, 0.0]
max = [0.03, 0.03, 0.06]
open = ["+z"]

[[geometry]]
name = "lifter"
type = "cylinder"
material = "grain"
base = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
radius = 0.01
length = 0.02

[[geometry.motion]]
type = "translation"
velocity = [0.0, 0.0, 0.5]
start = 0.0
end = 1.0

[[particles]]
material = "grain"
size = { type = "uniform", min = 0.002, max = 0.003 }
region = { type = "box", min = [-0.028, -0.028, 0.03], max = [0.028, 0.028, 0.058] }
fill = { type = "random", count = 30, seed = 3 }

[[particles]]
material = "grain"
shape = { type = "rod", length = 0.012, diameter = 0.004, count = 3 }
region = { type = "box", min = [-0.028, -0.028, 0.002], max = [0.028, 0.028, 0.028] }
fill = { type = "random", count = 5, seed = 5 }
"#;

fn scene(text: &str) -> Scene {
    Scene::from_toml(text, "test.toml", Path::new(".")).unwrap()
}

/// A fresh folder, removed when the test ends.
struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn temp_dir(name: &str) -> TempDir {
    let d = std::env::temp_dir().join(format!("demcal-output-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TempDir(d)
}

/// A `.vtp` file split into its XML and its appended bytes (after the `_`).
struct Vtp {
    xml: String,
    appended: Vec<u8>,
}

impl Vtp {
    fn read(path: &Path) -> Vtp {
        let bytes = std::fs::read(path).unwrap();
        let marker = b"<AppendedData encoding=\"raw\">";
        match bytes.windows(marker.len()).position(|w| w == marker) {
            Some(at) => {
                let underscore = at + bytes[at..].iter().position(|&b| b == b'_').unwrap();
                Vtp {
                    xml: String::from_utf8(bytes[..at].to_vec()).unwrap(),
                    appended: bytes[underscore + 1..].to_vec(),
                }
            }
            None => Vtp {
                xml: String::from_utf8(bytes).unwrap(),
                appended: Vec::new(),
            },
        }
    }

    /// The opening tag of the first array called `name`, and the text up to its closing tag.
    fn array(&self, name: &str) -> (&str, &str) {
        let at = self
            .xml
            .find(&format!("Name=\"{name}\""))
            .unwrap_or_else(|| panic!("no array {name}"));
        let start = self.xml[..at].rfind('<').unwrap();
        let end = at + self.xml[at..].find('>').unwrap();
        let tag = &self.xml[start..=end];
        let body = &self.xml[end + 1..];
        let body = &body[..body.find("</").unwrap_or(0)];
        (tag, body)
    }

    /// The raw bytes of an appended array, checking its UInt64 byte-count header.
    fn block(&self, name: &str) -> &[u8] {
        let offset: usize = attr(self.array(name).0, "offset").parse().unwrap();
        let len = u64::from_le_bytes(self.appended[offset..offset + 8].try_into().unwrap());
        &self.appended[offset + 8..offset + 8 + len as usize]
    }

    fn f64s(&self, name: &str) -> Vec<f64> {
        let (tag, body) = self.array(name);
        if tag.contains("format=\"ascii\"") {
            return body
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
        }
        assert!(tag.contains("type=\"Float64\""), "{tag}");
        self.block(name)
            .chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    fn i32s(&self, name: &str) -> Vec<i32> {
        let (tag, body) = self.array(name);
        if tag.contains("format=\"ascii\"") {
            return body
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
        }
        assert!(tag.contains("type=\"Int32\""), "{tag}");
        self.block(name)
            .chunks(4)
            .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    fn piece(&self, key: &str) -> usize {
        let at = self.xml.find("<Piece").unwrap();
        attr(&self.xml[at..], key).parse().unwrap()
    }
}

/// The value of attribute `key` in the first tag of `text`.
fn attr<'a>(text: &'a str, key: &str) -> &'a str {
    let tag = &text[..text.find('>').unwrap()];
    let at = tag
        .find(&format!(" {key}=\""))
        .unwrap_or_else(|| panic!("no {key} in {tag}"));
    let rest = &tag[at + key.len() + 3..];
    &rest[..rest.find('"').unwrap()]
}

/// (timestep, part, file) of every `<DataSet>` of a collection.
fn collection(path: &Path) -> Vec<(f64, usize, String)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.trim_start().starts_with("<DataSet"))
        .map(|l| {
            let l = l.trim_start();
            (
                attr(l, "timestep").parse().unwrap(),
                attr(l, "part").parse().unwrap(),
                attr(l, "file").to_string(),
            )
        })
        .collect()
}

#[test]
fn particles_read_back_from_the_appended_block() {
    let mut s = scene(SCENE);
    let dir = temp_dir("particles");
    let mut snapshots = Snapshots::new(&dir, SnapshotOptions::default());
    snapshots.write(&mut s.simulation).unwrap();
    let sim = &s.simulation;
    let v = Vtp::read(&dir.join("particles_00000000.vtp"));
    assert!(v.xml.contains("header_type=\"UInt64\""));
    let n = sim.particles.len();
    assert_eq!(n, 30 + 5 * 3);
    assert_eq!(v.piece("NumberOfPoints"), n);
    assert_eq!(v.piece("NumberOfVerts"), n);

    // Each array's offset is where the one before it ended: header plus data, nothing between.
    let mut offsets: Vec<(usize, usize)> = v
        .xml
        .match_indices("offset=\"")
        .map(|(at, _)| {
            let o: usize = attr(&v.xml[v.xml[..at].rfind('<').unwrap()..], "offset")
                .parse()
                .unwrap();
            let len = u64::from_le_bytes(v.appended[o..o + 8].try_into().unwrap()) as usize;
            (o, len)
        })
        .collect();
    offsets.sort();
    assert_eq!(offsets[0].0, 0);
    for w in offsets.windows(2) {
        assert_eq!(w[1].0, w[0].0 + 8 + w[0].1);
    }
    let (last, len) = offsets[offsets.len() - 1];
    assert_eq!(
        &v.appended[last + 8 + len..],
        b"\n  </AppendedData>\n</VTKFile>\n"
    );

    // Points and radii in stable-id order.
    let ids = v.i32s("id");
    assert_eq!(ids, (0..n as i32).collect::<Vec<_>>());
    let k = sim.particles.id.iter().position(|&i| i == 7).unwrap();
    assert_eq!(v.f64s("radius")[7], sim.particles.radius[k]);
    let points = v.f64s("Points");
    assert_eq!(points.len(), 3 * n);
    assert_eq!(points[21..24], sim.particles.position[k].to_array());
    assert_eq!(v.f64s("TimeValue"), vec![0.0]);

    // The first 30 spheres are free; the rods' spheres carry their clump and its orientation.
    let clump = v.i32s("clump_id");
    assert!(clump[..30].iter().all(|&c| c == particles::FREE_SPHERE));
    assert_eq!(clump[30..], [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4]);
    let q = v.f64s("orientation");
    assert_eq!(q.len(), 4 * n);
    assert_eq!(q[..4], [1.0, 0.0, 0.0, 0.0]);
    let rod = sim.bodies.rotation[0].orientation;
    assert_eq!(q[4 * 30..4 * 31], [rod.w, rod.x, rod.y, rod.z]);
    let axis = v.f64s("clump_axis");
    let along = glam::DVec3::from_slice(&axis[3 * 30..3 * 31]);
    // A rod's spheres lie on its first axis.
    let (a, b) = (
        glam::DVec3::from_slice(&points[3 * 30..3 * 31]),
        glam::DVec3::from_slice(&points[3 * 32..3 * 33]),
    );
    assert!((b - a).normalize().cross(along).length() < 1e-9);

    let pvd = collection(&dir.join("particles.pvd"));
    assert_eq!(pvd, vec![(0.0, 0, "particles_00000000.vtp".to_string())]);
}

#[test]
fn the_series_lists_every_time_and_writes_still_geometry_once() {
    let mut s = scene(SCENE);
    let dir = temp_dir("series");
    let mut snapshots = Snapshots::new(&dir, SnapshotOptions::default());
    let sim = &mut s.simulation;
    let mut times = Vec::new();
    for _ in 0..3 {
        snapshots.write(sim).unwrap();
        times.push(sim.time);
        sim.run(20).unwrap();
    }
    // The last state twice (a run's closing snapshot): listed once.
    snapshots.write(sim).unwrap();
    snapshots.write(sim).unwrap();
    times.push(sim.time);
    assert_eq!(snapshots.count(), 4);

    let particles = collection(&dir.join("particles.pvd"));
    assert_eq!(
        particles.iter().map(|e| e.0).collect::<Vec<_>>(),
        times,
        "{particles:?}"
    );
    let geometry = collection(&dir.join("geometry.pvd"));
    let still: Vec<_> = geometry.iter().filter(|e| e.1 == 0).collect();
    let moving: Vec<_> = geometry.iter().filter(|e| e.1 == 1).collect();
    assert_eq!(still.len(), 4);
    assert!(still.iter().all(|e| e.2 == "geometry_static_00000000.vtp"));
    assert_eq!(moving.len(), 4);
    assert_eq!(moving[3].2, "geometry_00000060.vtp");

    // Floor (one polygon cut by the domain) and box (five walls) in the static file; the
    // cylinder, rising, in the moving ones.
    let fixed = Vtp::read(&dir.join("geometry_static_00000000.vtp"));
    assert_eq!(fixed.i32s("geometry_id"), vec![0, 1, 1, 1, 1, 1]);
    assert!(fixed.xml.contains("Name=\"geometry_names\""));
    let floor = fixed.f64s("Points");
    // The domain's bottom-face outline is below the floor: the floor's cut is the domain's width.
    let xs: Vec<f64> = floor[..12].chunks(3).map(|p| p[0]).collect();
    assert!(xs.iter().any(|&x| (x - 0.05).abs() < 1e-12), "{xs:?}");
    let z_of = |file: &str| {
        let v = Vtp::read(&dir.join(file));
        assert_eq!(v.piece("NumberOfPolys"), geometry::SEGMENTS);
        v.f64s("Points")[2]
    };
    let (z0, z1) = (z_of(&moving[0].2), z_of(&moving[3].2));
    assert!((z1 - z0 - 0.5 * times[3]).abs() < 1e-9, "{z0} {z1}");
}

#[test]
fn a_geometry_that_starts_moving_leaves_the_static_file() {
    let mut s = scene(SCENE);
    let dir = temp_dir("servo");
    let mut snapshots = Snapshots::new(&dir, SnapshotOptions::default());
    let sim = &mut s.simulation;
    snapshots.write(sim).unwrap();
    // The bin is given a motion half-way, as a servo-controlled plate is.
    sim.geometry_mut("bin").unwrap().motion = vec![crate::Motion::Translation {
        velocity: glam::DVec3::new(0.0, 0.0, 0.1),
        start: 0.0,
        end: 1.0,
    }];
    sim.run(20).unwrap();
    snapshots.write(sim).unwrap();
    let geometry = collection(&dir.join("geometry.pvd"));
    let files: Vec<&str> = geometry.iter().map(|e| e.2.as_str()).collect();
    assert_eq!(
        files,
        [
            "geometry_static_00000000.vtp",
            "geometry_00000000.vtp",
            "geometry_static_00000020.vtp",
            "geometry_00000020.vtp"
        ]
    );
    // The first time keeps the bin in its static file; from the second on it moves.
    let ids = |f: &str| {
        let mut ids = Vtp::read(&dir.join(f)).i32s("geometry_id");
        ids.dedup();
        ids
    };
    assert_eq!(ids(files[0]), [0, 1]);
    assert_eq!(ids(files[1]), [2]);
    assert_eq!(ids(files[2]), [0]);
    assert_eq!(ids(files[3]), [1, 2]);
}

#[test]
fn binary_is_smaller_than_ascii_and_reads_the_same() {
    let mut s = scene(SCENE);
    let (bin, txt) = (temp_dir("binary"), temp_dir("ascii"));
    Snapshots::new(&bin, SnapshotOptions::default())
        .write(&mut s.simulation)
        .unwrap();
    let ascii = SnapshotOptions {
        encoding: Encoding::Ascii,
        contacts: false,
    };
    Snapshots::new(&txt, ascii)
        .write(&mut s.simulation)
        .unwrap();
    let name = "particles_00000000.vtp";
    let size = |d: &Path| std::fs::metadata(d.join(name)).unwrap().len();
    assert!(size(&bin) < size(&txt), "{} {}", size(&bin), size(&txt));
    let (b, t) = (Vtp::read(&bin.join(name)), Vtp::read(&txt.join(name)));
    assert!(t.appended.is_empty());
    for array in ["radius", "velocity", "Points", "orientation"] {
        assert_eq!(b.f64s(array), t.f64s(array), "{array}");
    }
    assert_eq!(b.i32s("clump_id"), t.i32s("clump_id"));
    let names = Vtp::read(&txt.join("geometry_static_00000000.vtp"));
    let (_, codes) = names.array("geometry_names");
    // "floor", "bin", "lifter" as byte codes, each ending with 0.
    assert!(codes
        .trim_start()
        .starts_with("102 108 111 111 114 0 98 105 110 0"));
}

/// Spheres on a 3 x 2 grid 0.2 % closer than touching, without gravity: every neighbour pushes.
fn grid() -> crate::Simulation {
    use crate::material::{Interaction, Material, MaterialTable};
    let mut table = MaterialTable::new();
    let m = table.add_material(Material {
        name: "grain".into(),
        density: 1200.0,
        poisson_ratio: 0.3,
        shear_modulus: 1e7,
    });
    table.set_interaction(
        m,
        m,
        Interaction {
            restitution: 0.5,
            static_friction: 0.5,
            rolling_friction: 0.05,
            surface_energy: 0.0,
        },
    );
    let mut particles = crate::Particles::default();
    for x in 0..3 {
        for y in 0..2 {
            let at = glam::DVec3::new(x as f64, y as f64, 0.0) * 0.003992;
            particles.push(at, glam::DVec3::ZERO, 0.002, 1200.0, m);
        }
    }
    crate::Simulation::new(
        particles,
        table,
        Vec::new(),
        crate::SimulationParams {
            time_step: 1e-6,
            gravity: glam::DVec3::ZERO,
            skin: 4e-4,
            ..Default::default()
        },
    )
}

#[test]
fn contacts_are_written_when_asked_and_leave_the_run_unchanged() {
    let mut with = grid();
    let mut without = grid();
    let n = with.particles.len();
    assert_eq!(n, 3 * 2);
    let dir = temp_dir("contacts");
    let options = SnapshotOptions {
        contacts: true,
        ..Default::default()
    };
    let mut snapshots = Snapshots::new(&dir, options);
    snapshots.write(&mut with).unwrap();
    let v = Vtp::read(&dir.join("contacts_00000000.vtp"));
    // A 3 x 2 grid has 3 + 4 neighbour pairs.
    assert_eq!(v.piece("NumberOfLines"), 7);
    assert_eq!(v.piece("NumberOfPoints"), n);
    let normal = v.f64s("normal_force");
    assert!(normal.iter().all(|&f| f > 0.0), "{normal:?}");
    let overlap = v.f64s("overlap");
    assert!(
        overlap.iter().all(|&d| (d - 8e-6).abs() < 1e-9),
        "{overlap:?}"
    );
    // Nothing slides at the start: the force is all normal.
    let force = v.f64s("force");
    assert_eq!(force.len(), 3 * 7);
    let tangential = v.f64s("tangential_force");
    assert!(tangential.iter().all(|t| t.abs() < 1e-9 * normal[0]));
    assert_eq!(collection(&dir.join("contacts.pvd")).len(), 1);

    // Gathering the contacts is read-only: the runs with and without stay bit-identical.
    with.run(10).unwrap();
    without.run(10).unwrap();
    snapshots.write(&mut with).unwrap();
    with.run(5).unwrap();
    without.run(5).unwrap();
    assert_eq!(with.particles.position, without.particles.position);
    assert_eq!(with.particles.velocity, without.particles.velocity);
    assert_eq!(collection(&dir.join("contacts.pvd")).len(), 2);
}

#[test]
fn a_wrong_format_names_the_key() {
    let text = SCENE.replace("[[material]]", "[output]\nformat = \"xml\"\n\n[[material]]");
    let e = Scene::from_toml(&text, "test.toml", Path::new("."))
        .err()
        .unwrap()
        .to_string();
    assert_eq!(
        e,
        "test.toml: output.format: unknown format \"xml\" (expected \"binary\" or \"ascii\")"
    );
    let text = SCENE.replace(
        "[[material]]",
        "[output]\ncontacts = \"yes\"\n\n[[material]]",
    );
    let e = Scene::from_toml(&text, "test.toml", Path::new("."))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("output.contacts"), "{e}");
}

#[test]
fn polyhedra_are_written_as_surfaces() {
    // The wedges above the lifter (the random fill does not avoid geometry).
    let text = SCENE
        .replace(
            r#"shape = { type = "rod", length = 0.012, diameter = 0.004, count = 3 }"#,
            r#"shape = { type = "polyhedron", class = "horse_tooth" }"#,
        )
        .replace(
            "max = [0.028, 0.028, 0.028] }",
            "max = [0.028, 0.028, 0.028] }\n",
        )
        .replace(
            "region = { type = \"box\", min = [-0.028, -0.028, 0.002], max = [0.028, 0.028, 0.028] }\n",
            "region = { type = \"box\", min = [-0.028, -0.028, 0.03], max = [0.028, 0.028, 0.058] }",
        );
    let mut s = scene(&text);
    let dir = temp_dir("polyhedra");
    let mut snapshots = Snapshots::new(&dir, SnapshotOptions::default());
    snapshots.write(&mut s.simulation).unwrap();
    let sim = &s.simulation;
    // Five wedges of 8 corners and 6 faces; their proxies are among the particles.
    assert_eq!(sim.particles.len(), 30 + 5);
    let v = Vtp::read(&dir.join("polyhedra_00000000.vtp"));
    assert_eq!(v.piece("NumberOfPoints"), 5 * 8);
    assert_eq!(v.piece("NumberOfPolys"), 5 * 6);
    let listed = collection(&dir.join("polyhedra.pvd"));
    assert_eq!(listed.len(), 1);
    assert_eq!(listed[0].2, "polyhedra_00000000.vtp");
    // Every written corner lies on its body's surface: within the bounding radius of a body
    // centre, and the ids are the proxies'.
    let ids = v.i32s("id");
    assert_eq!(ids.len(), 30);
    let proxies: Vec<i32> = (0..sim.particles.len())
        .filter(|&k| sim.bodies.polyhedra.is_polyhedron(sim.particles.body[k]))
        .map(|k| sim.particles.id[k] as i32)
        .collect();
    assert!(ids.iter().all(|i| proxies.contains(i)));
}
