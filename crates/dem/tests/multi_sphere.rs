//! Shapes fitted to a volume error in scene files: `maize_kernel` with `volume_error`, and
//! `multi_sphere` from a closed STL solid.

use dem::maize_kernel::KernelShape;
use dem::scene::Scene;
use glam::DVec3;
use std::path::{Path, PathBuf};
use test_support::{Material, Materials};

fn materials() -> String {
    let crop = Materials {
        particle: Material {
            name: "crop",
            density: 1000.0,
            ..Materials::default().particle
        },
        wall_first: true,
        ..Materials::default()
    };
    format!(
        r#"[simulation]
duration = 0.01
{}
[[geometry]]
name = "floor"
type = "plane"
material = "steel"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
"#,
        crop.toml()
    )
}

/// A scene of one particle type with `shape`, ten of them dropped in a box.
fn scene_text(shape: &str) -> String {
    format!(
        r#"{}
[[particle_type]]
name = "k"
material = "crop"
shape = {shape}

[[particles]]
types = ["k"]
region = {{ type = "box", min = [-0.03, -0.03, 0.01], max = [0.03, 0.03, 0.06] }}
fill = {{ type = "random", count = 10, seed = 3 }}
"#,
        materials()
    )
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-multi-sphere-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A closed 10 x 6 x 4 box (in the file's units), 12 triangles wound outward.
fn write_box_stl(path: &Path, open: bool) {
    let (lo, hi) = (DVec3::ZERO, DVec3::new(10.0, 6.0, 4.0));
    let p = |i: usize| {
        stl_io::Vertex::new([
            if i & 1 == 0 { lo.x } else { hi.x } as f32,
            if i & 2 == 0 { lo.y } else { hi.y } as f32,
            if i & 4 == 0 { lo.z } else { hi.z } as f32,
        ])
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut tris: Vec<stl_io::Triangle> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .map(|t| stl_io::Triangle {
            normal: stl_io::Normal::new([0.0, 0.0, 0.0]),
            vertices: t.map(p),
        })
        .collect();
    if open {
        tris.pop();
    }
    let mut f = std::fs::File::create(path).unwrap();
    stl_io::write_stl(&mut f, tris.iter()).unwrap();
}

#[test]
fn kernels_fitted_to_a_volume_error_build_within_it() {
    for class in KernelShape::KINDS {
        let text = scene_text(&format!(
            "{{ type = \"maize_kernel\", class = \"{class}\", volume_error = 0.05 }}"
        ));
        let scene =
            Scene::from_toml(&text, "scene.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.notes.len(), 1, "{:?}", scene.notes);
        let note = &scene.notes[0];
        println!("{note}");
        for part in [
            "maize kernel fitted with",
            "spheres",
            "surface error",
            "smallest sphere radius",
        ] {
            assert!(note.contains(part), "{note}");
        }
        // Every body is a kernel at scale 1: its mass over the density is the clump's volume.
        let target = KernelShape::published(class).unwrap().volume();
        let masses = &scene.simulation.bodies.mass;
        assert_eq!(masses.len(), 10, "{class}");
        for m in masses {
            let volume = m / 1000.0;
            assert!(
                (volume / target - 1.0).abs() <= 0.05,
                "{class}: {volume:e} vs {target:e}"
            );
        }
    }
}

#[test]
fn an_stl_solid_is_fitted_relative_to_the_scene_folder() {
    let dir = temp_dir("scene");
    write_box_stl(&dir.join("brick.stl"), false);
    let text = scene_text(
        "{ type = \"multi_sphere\", file = \"brick.stl\", file_scale = 0.001, volume_error = 0.05, max_spheres = 60 }",
    );
    let scene = Scene::from_toml(&text, "scene.toml", &dir).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        scene.notes[0].contains("solid brick.stl fitted with"),
        "{:?}",
        scene.notes
    );
    for m in &scene.simulation.bodies.mass {
        assert!((m / 1000.0 / 240e-9 - 1.0).abs() <= 0.05, "{m}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn fit_errors_name_the_key_and_the_file() {
    let dir = temp_dir("errors");
    let err = |shape: &str| {
        Scene::from_toml(&scene_text(shape), "scene.toml", &dir)
            .err()
            .unwrap_or_else(|| panic!("{shape} should fail"))
            .to_string()
    };
    let e = err("{ type = \"multi_sphere\", file = \"missing.stl\", volume_error = 0.05 }");
    assert!(
        e.contains("particle_type[0].shape.file") && e.contains("missing.stl"),
        "{e}"
    );
    write_box_stl(&dir.join("open.stl"), true);
    let e = err("{ type = \"multi_sphere\", file = \"open.stl\" }");
    assert!(
        e.contains("particle_type[0].shape.file")
            && e.contains("open.stl")
            && e.contains("not closed"),
        "{e}"
    );
    let e = err("{ type = \"maize_kernel\", class = \"flat\", count = 5, volume_error = 0.05 }");
    assert!(
        e.contains("particle_type[0].shape.volume_error") && e.contains("not both"),
        "{e}"
    );
    let e = err("{ type = \"maize_kernel\", class = \"flat\" }");
    assert!(
        e.contains("particle_type[0].shape.count") && e.contains("volume_error"),
        "{e}"
    );
    let e = err("{ type = \"maize_kernel\", class = \"flat\", count = 5, max_spheres = 9 }");
    assert!(e.contains("particle_type[0].shape.max_spheres"), "{e}");
    let e = err("{ type = \"maize_kernel\", class = \"flat\", volume_error = 1.5 }");
    assert!(e.contains("particle_type[0].shape.volume_error"), "{e}");
    let e = err(
        "{ type = \"maize_kernel\", class = \"flat\", volume_error = 0.05, min_radius_ratio = 0 }",
    );
    assert!(e.contains("particle_type[0].shape.min_radius_ratio"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
