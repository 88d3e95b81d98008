use super::mesh::MeshSolid;
use super::*;

/// Writes a binary STL of the triangles to `path`.
fn write_stl(path: &std::path::Path, triangles: &[[DVec3; 3]]) {
    let v = |p: DVec3| stl_io::Vertex::new([p.x as f32, p.y as f32, p.z as f32]);
    let tris: Vec<stl_io::Triangle> = triangles
        .iter()
        .map(|[a, b, c]| {
            let n = (*b - *a).cross(*c - *a).normalize();
            stl_io::Triangle {
                normal: stl_io::Normal::new([n.x as f32, n.y as f32, n.z as f32]),
                vertices: [v(*a), v(*b), v(*c)],
            }
        })
        .collect();
    let mut f = std::fs::File::create(path).unwrap();
    stl_io::write_stl(&mut f, tris.iter()).unwrap();
}

/// A closed box's 12 triangles, wound outward.
fn box_triangles(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
    let p = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    // Quads (outward by the right-hand rule), each split in two.
    let quads = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    quads
        .iter()
        .flat_map(|q| [[p(q[0]), p(q[1]), p(q[2])], [p(q[0]), p(q[2]), p(q[3])]])
        .collect()
}

/// A closed ellipsoid with semi-axes `h`: a UV sphere of `rings` x `segments`, scaled.
fn ellipsoid_triangles(h: DVec3, rings: usize, segments: usize) -> Vec<[DVec3; 3]> {
    let at = |i: usize, j: usize| {
        // One vertex at each pole (sin(0) * cos(phi) would give 0.0 and -0.0).
        if i == 0 || i == rings {
            return DVec3::new(0.0, 0.0, if i == 0 { h.z } else { -h.z });
        }
        let theta = PI * i as f64 / rings as f64;
        let phi = 2.0 * PI * (j % segments) as f64 / segments as f64;
        h * DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    };
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if i != 0 {
                out.push([a, b, d]);
            }
            if i != rings - 1 {
                out.push([b, c, d]);
            }
        }
    }
    out
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-sphere-fit-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn kernel_classes_fit_within_five_percent() {
    let options = FitOptions::default();
    for kind in KernelShape::KINDS {
        let shape = KernelShape::published(kind).unwrap();
        let fit = shape.fit_to(&options).unwrap();
        let q = &fit.quality;
        println!(
            "{kind}: {} spheres, volume {:+.2} %, symmetric difference {:.1} %, surface rms {:.3} mm max {:.3} mm, smallest {:.3} mm, time step x{:.2}",
            fit.template.spheres.len(),
            100.0 * q.volume_error,
            100.0 * q.symmetric_difference,
            1e3 * q.surface_rms,
            1e3 * q.surface_max,
            1e3 * q.smallest_radius,
            fit.time_step_factor()
        );
        assert!(q.volume_error.abs() <= 0.05, "{kind}: {}", q.volume_error);
        assert!(fit.template.spheres.len() < options.max_spheres, "{kind}");
        assert!(
            q.smallest_radius >= options.min_radius_ratio * q.largest_radius * (1.0 - 1e-9),
            "{kind}"
        );
        // The clump's outer surface lies within 12 % of the equal-volume radius of the
        // kernel's on average (about 0.4 mm), and nowhere further than 40 %.
        assert!(
            q.surface_rms < 0.12 * q.equal_volume_radius,
            "{kind}: {}",
            q.surface_rms
        );
        assert!(
            q.surface_max < 0.40 * q.equal_volume_radius,
            "{kind}: {}",
            q.surface_max
        );
        assert!(
            q.symmetric_difference < 0.35,
            "{kind}: {}",
            q.symmetric_difference
        );
    }
}

#[test]
fn error_shrinks_as_the_target_tightens() {
    for kind in ["horse_tooth", "near_spherical"] {
        let shape = KernelShape::published(kind).unwrap();
        let fits: Vec<SphereFit> = [0.10, 0.05, 0.03]
            .iter()
            .map(|&e| {
                shape
                    .fit_to(&FitOptions {
                        volume_error: e,
                        ..FitOptions::default()
                    })
                    .unwrap()
            })
            .collect();
        for (f, e) in fits.iter().zip([0.10, 0.05, 0.03]) {
            println!(
                "{kind} at {e}: {} spheres, {:+.2} %",
                f.template.spheres.len(),
                100.0 * f.quality.volume_error
            );
            assert!(f.quality.volume_error.abs() <= e, "{kind} {e}");
        }
        assert!(
            fits[2].template.spheres.len() >= fits[0].template.spheres.len(),
            "{kind}"
        );
        assert!(
            fits[2].quality.volume_error.abs() <= fits[0].quality.volume_error.abs() + 1e-12,
            "{kind}"
        );
    }
}

#[test]
fn stl_box_and_ellipsoid_fit_and_their_volumes_match() {
    let dir = temp_dir("closed");
    // A 10 x 6 x 4 mm box, written in mm and read with scale 0.001.
    let boxed = dir.join("box.stl");
    write_stl(
        &boxed,
        &box_triangles(DVec3::ZERO, DVec3::new(10.0, 6.0, 4.0)),
    );
    let solid = MeshSolid::read(&boxed, 1e-3).unwrap();
    assert!(
        (solid.volume() / 240e-9 - 1.0).abs() < 1e-9,
        "{}",
        solid.volume()
    );
    assert!((solid.centroid - DVec3::new(5e-3, 3e-3, 2e-3)).length() < 1e-9);
    assert!(solid.inside(DVec3::new(5e-3, 3e-3, 2e-3)));
    assert!(!solid.inside(DVec3::new(11e-3, 3e-3, 2e-3)));
    // An ellipsoid of semi-axes 5, 4, 3 mm: the tessellation's volume approaches the analytic
    // one (a UV sphere of 48 x 96 is 0.3 % smaller).
    let h = DVec3::new(5e-3, 4e-3, 3e-3);
    let ell = dir.join("ellipsoid.stl");
    write_stl(&ell, &ellipsoid_triangles(h, 48, 96));
    let e = MeshSolid::read(&ell, 1.0).unwrap();
    let analytic = 4.0 / 3.0 * PI * h.x * h.y * h.z;
    assert!(
        (e.volume() / analytic - 1.0).abs() < 0.005,
        "{} vs {analytic}",
        e.volume()
    );
    assert!(e.centroid.length() < 1e-7);
    for (name, solid) in [("box", &solid), ("ellipsoid", &e)] {
        let fit = fit(solid, &FitOptions::default()).unwrap();
        let q = &fit.quality;
        println!(
            "{name}: {} spheres, volume {:+.2} %, symmetric difference {:.1} %, surface rms {:.3} mm, time step x{:.2}",
            fit.template.spheres.len(),
            100.0 * q.volume_error,
            100.0 * q.symmetric_difference,
            1e3 * q.surface_rms,
            fit.time_step_factor()
        );
        assert!(q.volume_error.abs() <= 0.05, "{name}: {}", q.volume_error);
        assert!(fit.time_step_factor() > 0.0 && fit.time_step_factor() < 1.0);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_open_mesh_is_refused() {
    let dir = temp_dir("open");
    let path = dir.join("open_box.stl");
    let mut t = box_triangles(DVec3::ZERO, DVec3::ONE);
    t.truncate(10); // no +x face
    write_stl(&path, &t);
    let e = MeshSolid::read(&path, 1.0).unwrap_err();
    println!("{e}");
    assert!(
        e.contains("open_box.stl") && e.contains("not closed"),
        "{e}"
    );
    assert!(!e.contains('\n'));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn impossible_targets_say_what_was_reached() {
    let shape = KernelShape::published("horse_tooth").unwrap();
    let e = shape
        .fit_to(&FitOptions {
            volume_error: 0.001,
            max_spheres: 3,
            ..FitOptions::default()
        })
        .unwrap_err();
    assert!(
        e.contains("max_spheres = 3") && e.contains("volume error"),
        "{e}"
    );
}
