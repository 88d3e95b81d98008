//! The `demcal` binary end to end: simulate writes what it promises, bad input gives one line.

use std::path::{Path, PathBuf};

mod common;
use common::*;

const SCENE: &str = r#"
[simulation]
duration = 0.05
time_step_percent = 20
domain = { min = [-0.1, -0.1, -0.1], max = [0.1, 0.1, 0.2] }

[output]
directory = "out"
snapshot_interval = 0.02
force_interval = 0.01

[[material]]
name = "glass"
density = 2500
poisson_ratio = 0.25
shear_modulus = 1e7

[[interaction]]
materials = ["glass", "glass"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.05

[[geometry]]
name = "cup"
type = "cylinder"
material = "glass"
base = [0.0, 0.0, 0.0]
radius = 0.02
length = 0.05
caps = "bottom"

[[particles]]
material = "glass"
size = { type = "classes", radii = [0.002, 0.0015], fractions = [0.5, 0.5], basis = "mass" }
region = { type = "cylinder", base = [0.0, 0.0, 0.0], radius = 0.02, length = 0.05 }
fill = { type = "random", count = 150, seed = 4 }
"#;

/// The XML header of a binary `.vtp` and the Float64 values of its array `name`, read from the
/// appended block (a UInt64 byte count, then the values) at the array's offset.
fn appended_f64s(bytes: &[u8], name: &str) -> (String, Vec<f64>) {
    let marker = b"<AppendedData encoding=\"raw\">";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .expect("appended data");
    let xml = String::from_utf8(bytes[..at].to_vec()).unwrap();
    let data = &bytes[at + bytes[at..].iter().position(|&b| b == b'_').unwrap() + 1..];
    let tag = &xml[xml.find(&format!("Name=\"{name}\"")).unwrap()..];
    let tag = &tag[..tag.find('>').unwrap()];
    let offset: usize = tag
        .split("offset=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let len = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap()) as usize;
    let values = data[offset + 8..offset + 8 + len]
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (xml, values)
}

fn write(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn simulate_writes_snapshots_loads_and_a_summary() {
    let dir = temp_dir("ok");
    let scene = write(&dir, SCENE);
    let out = demcal()
        .args(["simulate", scene.to_str().unwrap(), "--threads", "2"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary = stdout.lines().last().unwrap();
    assert!(
        summary.starts_with("simulate: particles=150 steps="),
        "{summary}"
    );

    let mut vtp: Vec<_> = std::fs::read_dir(dir.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("particles_") && n.ends_with(".vtp"))
        .collect();
    vtp.sort();
    // t = 0, 0.02, 0.04 and the end, each listed with its time in particles.pvd.
    assert_eq!(vtp.len(), 4, "{vtp:?}");
    let pvd = std::fs::read_to_string(dir.join("out").join("particles.pvd")).unwrap();
    let listed: Vec<&str> = pvd.lines().filter(|l| l.contains("<DataSet")).collect();
    assert_eq!(listed.len(), 4, "{pvd}");
    assert!(listed[0].contains("timestep=\"0\""), "{}", listed[0]);
    assert!(
        listed[3].contains(&format!("file=\"{}\"", vtp[3])),
        "{}",
        listed[3]
    );
    // The cup, which does not move, is written once.
    let geometry = std::fs::read_to_string(dir.join("out").join("geometry.pvd")).unwrap();
    assert_eq!(
        geometry
            .matches("file=\"geometry_static_00000000.vtp\"")
            .count(),
        4,
        "{geometry}"
    );

    let bytes = std::fs::read(dir.join("out").join(&vtp[3])).unwrap();
    let (xml, points) = appended_f64s(&bytes, "Points");
    assert!(xml.contains("NumberOfPoints=\"150\""));
    for field in [
        "radius",
        "material_id",
        "velocity",
        "angular_velocity",
        "clump_id",
    ] {
        assert!(xml.contains(&format!("Name=\"{field}\"")), "{field}");
    }
    // Every particle is inside the cup at the end (it fell and stayed).
    assert_eq!(points.len(), 3 * 150);
    assert!(points
        .chunks(3)
        .all(|p| (p[0] * p[0] + p[1] * p[1]).sqrt() < 0.02 && p[2] > 0.0));

    let csv = std::fs::read_to_string(dir.join("out").join("geometry_forces.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,cup_fx_n,cup_fy_n,cup_fz_n,cup_tx_nm,cup_ty_nm,cup_tz_nm"
    );
    let rows: Vec<&str> = lines.collect();
    // t = 0, 0.01, ..., 0.05.
    assert_eq!(rows.len(), 6);
}

#[test]
fn bad_scene_gives_one_line_naming_file_and_key() {
    let dir = temp_dir("bad");
    let scene = write(
        &dir,
        &SCENE.replace("restitution = 0.5", "restitution = 1.5"),
    );
    let out = demcal()
        .args(["simulate", scene.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!(
            "error: {}: interaction[0].restitution: expected a value in (0, 1]",
            scene.display()
        )),
        "{stderr}"
    );
}

#[test]
fn exploding_simulation_stops_with_the_reason() {
    let dir = temp_dir("explode");
    let text = SCENE
        .replace(
            "fill = { type = \"random\", count = 150, seed = 4 }",
            "fill = { type = \"random\", count = 150, seed = 4 }\nvelocity = [0.0, 0.0, 30.0]",
        )
        .replace("length = 0.05\ncaps", "length = 0.5\ncaps");
    let scene = write(&dir, &text);
    let out = demcal()
        .args(["simulate", scene.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last = stderr.lines().last().unwrap();
    assert!(
        last.contains("left the simulation domain at t ="),
        "{stderr}"
    );
}

#[test]
fn bench_settle_prints_the_agreed_line() {
    let out = demcal()
        .args(["bench", "settle", "--steps", "300"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    let last = stdout.lines().last().unwrap();
    let fields: Vec<&str> = last.split(' ').collect();
    assert_eq!(fields[0], "settle:");
    assert_eq!(fields[1], "backend=cpu");
    let keys: Vec<&str> = fields[1..]
        .iter()
        .map(|f| f.split('=').next().unwrap())
        .collect();
    assert_eq!(
        keys,
        [
            "backend",
            "particles",
            "steps",
            "wall_s",
            "particle_steps_per_s",
            "bed_height_m",
            "kinetic_energy_j"
        ]
    );
    assert_eq!(fields[2], "particles=21160");
    assert_eq!(fields[3], "steps=300");
    // After 6 ms of free fall from rest the lattice has not moved far: the top is still near 0.17 m.
    let bed: f64 = fields[6]
        .trim_start_matches("bed_height_m=")
        .parse()
        .unwrap();
    assert!((bed - 0.17).abs() < 0.001, "{bed}");
}

#[test]
fn doe_design_then_analyze_and_optimize() {
    let dir = temp_dir("doe");
    let design = dir.join("design.csv");
    let out = demcal()
        .args([
            "doe",
            "design",
            "bbd",
            "--factors",
            "mu:0.2:0.6,e:0.1:0.5,k:1e6:1e8:log",
        ])
        .args(["--centers", "3", "--seed", "5", "--out"])
        .arg(&design)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&design).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "std_order,run_order,point_type,mu,e,k,mu_actual,e_actual,k_actual"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 15);
    let run_order: Vec<usize> = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    assert_eq!(run_order, (1..=15).collect::<Vec<_>>());
    // Add a response with known coefficients in coded units and analyse it back.
    let mut data =
        String::from("std_order,run_order,point_type,mu,e,k,mu_actual,e_actual,k_actual,angle\n");
    for r in &rows {
        let x: Vec<f64> = r[3..6].iter().map(|v| v.parse().unwrap()).collect();
        let y = 30.0 + 2.0 * x[0] - 1.0 * x[1] + 0.5 * x[2] + 0.75 * x[0] * x[0];
        data.push_str(&format!("{},{y}\n", r.join(",")));
    }
    let data_path = dir.join("data.csv");
    std::fs::write(&data_path, data).unwrap();
    let plots = dir.join("plots");
    let os = |a: &'static str| std::ffi::OsStr::new(a);
    let stdout = run_ok(&[
        os("doe"),
        os("analyze"),
        data_path.as_os_str(),
        os("--response"),
        os("angle"),
        os("--model"),
        os("mu,e,k,mu^2"),
        os("--json"),
        os("--plots"),
        plots.as_os_str(),
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let coded = &v["coefficients_coded"];
    for (term, want) in [
        ("Intercept", 30.0),
        ("mu", 2.0),
        ("e", -1.0),
        ("k", 0.5),
        ("mu^2", 0.75),
    ] {
        let got = coded[term].as_f64().unwrap();
        assert!((got - want).abs() < 1e-9, "{term}: {got}");
    }
    for f in ["predicted_vs_actual.svg", "contour.svg", "surface.svg"] {
        assert!(plots.join(f).exists(), "{f}");
    }
    let stdout = run_ok(&[
        os("doe"),
        os("optimize"),
        data_path.as_os_str(),
        os("--response"),
        os("angle"),
        os("--model"),
        os("quadratic"),
        os("--goal"),
        os("target=31"),
        os("--solutions"),
        os("3"),
    ]);
    assert!(stdout.contains("mu (actual)"), "{stdout}");
    let first = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("1 "))
        .unwrap();
    assert!(
        first.contains(" 31.00 ") && first.trim_end().ends_with("1.0000"),
        "{first}"
    );
}

#[test]
fn doe_errors_are_one_line() {
    let dir = temp_dir("doe-errors");
    let data = write(&dir, "A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,x\n");
    let cases: &[(&[&str], &str)] = &[
        (
            &["--response", "y"],
            "row 5, column 'y': 'x' is not a number",
        ),
        (&["--response", "z"], "column 'z' not found"),
    ];
    for (args, want) in cases {
        let out = demcal()
            .args(["doe", "analyze"])
            .arg(&data)
            .args(*args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(want), "{err}");
    }
    let out = demcal()
        .args(["doe", "design", "ccd", "--factors", "A:1:0"])
        .output()
        .unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("expected low < high"), "{err}");
    let out = demcal()
        .args(["doe", "design", "taguchi", "--factors", "3"])
        .output()
        .unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("unknown design 'taguchi'"), "{err}");
}

#[test]
fn test_command_prints_json_last() {
    let dir = temp_dir("test-cmd");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/tests/spheres_repose.toml"),
    )
    .unwrap()
    .replace("count = 1500", "count = 300")
    .replace("cylinder_height = 0.1", "cylinder_height = 0.04");
    let path = dir.join("repose.toml");
    std::fs::write(&path, text).unwrap();
    let stdout = run_ok(&[
        std::ffi::OsStr::new("test"),
        path.as_os_str(),
        std::ffi::OsStr::new("--json"),
        std::ffi::OsStr::new("--seed"),
        std::ffi::OsStr::new("2"),
    ]);
    let last = stdout.lines().last().unwrap();
    assert!(last.starts_with('{') && last.ends_with('}'), "{last}");
    for key in [
        "\"angle_of_repose_deg\":",
        "\"angle_std_deg\":",
        "\"heap_height_m\":",
        "\"particles\":300",
        "\"wall_s\":",
        "\"seed\":2",
    ] {
        assert!(last.contains(key), "{key} in {last}");
    }
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "test = \"angle_of_repose\"\n[angle_of_repose]\n").unwrap();
    let out = demcal().arg("test").arg(&bad).output().unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("material: missing [[material]]"), "{err}");
}

/// The surface spheres of a cone heap of slope `deg` (1 mm spheres whose tops trace the cone).
fn cone_spheres(deg: f64) -> Vec<[f64; 4]> {
    let (r, radius, step) = (0.001, 0.06, 0.0015);
    let slope = deg.to_radians().tan();
    let n = (radius / step) as i64;
    let mut out = Vec::new();
    for i in -n..=n {
        for j in -n..=n {
            let (x, y) = (i as f64 * step, j as f64 * step);
            let rho = (x * x + y * y).sqrt();
            if rho < radius {
                out.push([x, y, (radius - rho) * slope - r, r]);
            }
        }
    }
    out
}

#[test]
fn heap_angle_measures_csv_and_liggghts_dumps_alike() {
    let dir = temp_dir("heap-angle");
    let spheres = cone_spheres(35.0);
    let mut csv = String::from("id,x,y,z,radius\n");
    let mut dump = format!(
        "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS ff ff ff\n-1 1\n-1 1\n-1 1\nITEM: ATOMS id x y z radius\n",
        spheres.len()
    );
    for (k, s) in spheres.iter().enumerate() {
        csv.push_str(&format!("{k},{},{},{},{}\n", s[0], s[1], s[2], s[3]));
        dump.push_str(&format!("{k} {} {} {} {}\n", s[0], s[1], s[2], s[3]));
    }
    let (c, d) = (dir.join("heap.csv"), dir.join("final.dump"));
    std::fs::write(&c, csv).unwrap();
    std::fs::write(&d, dump).unwrap();
    let angle = |path: &Path| -> f64 {
        let out = run_ok(&[
            "heap-angle".as_ref(),
            path.as_os_str(),
            "--axis=-0.0,0".as_ref(),
            "--json".as_ref(),
        ]);
        let j: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
        j["angle_of_repose_deg"].as_f64().unwrap()
    };
    let (a, b) = (angle(&c), angle(&d));
    assert_eq!(a, b);
    assert!((a - 35.0).abs() < 0.5, "{a}");
    // A file without a radius column names what is missing.
    std::fs::write(&c, "x,y,z\n0,0,0\n").unwrap();
    let out = demcal()
        .args(["heap-angle".as_ref(), c.as_os_str()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("no column \"radius\""), "{err}");
}

#[test]
fn absurd_thread_and_job_counts_are_refused_at_once() {
    let dir = temp_dir("threads");
    let scene = write(&dir, SCENE);
    let cores = std::thread::available_parallelism().unwrap().get();
    let limit = format!("at most {} (4 per core, {cores} cores here)", 4 * cores);
    for cmd in ["simulate", "test", "bench"] {
        let mut c = demcal();
        match cmd {
            "bench" => c.args(["bench", "settle"]),
            _ => c.arg(cmd).arg(&scene),
        };
        c.args(["--threads", "100000"]);
        let err = one_line_error(&output_within(c, 20.0));
        assert_eq!(err, format!("error: --threads 100000: {limit}"), "{cmd}");
    }
    let study = dir.join("study.toml");
    std::fs::write(&study, slow_bowl()).unwrap();
    let mut c = demcal();
    c.arg("run").arg(&study).args(["--jobs", "0"]);
    let err = one_line_error(&output_within(c, 20.0));
    assert_eq!(err, "error: --jobs 0: expected at least 1");
    let mut c = demcal();
    c.arg("run").arg(&study).args(["--jobs", "100000"]);
    let err = one_line_error(&output_within(c, 20.0));
    assert_eq!(err, format!("error: --jobs 100000: {limit}"));
    // Nothing ran: no store was made.
    assert!(!dir.join("study.db").exists());
}

#[test]
fn heap_angle_refuses_radii_and_axes_that_are_not_positive_numbers() {
    let dir = temp_dir("heap-angle-bad");
    let csv = dir.join("heap.csv");
    for (radius, want) in [("-0.001", "-0.001"), ("nan", "NaN"), ("0", "0")] {
        std::fs::write(
            &csv,
            format!("x,y,z,radius\n0,0,0,0.001\n0.002,0,0,{radius}\n"),
        )
        .unwrap();
        let out = demcal().arg("heap-angle").arg(&csv).output().unwrap();
        assert_eq!(
            one_line_error(&out),
            format!(
                "error: {}: sphere 2: radius {want}: expected a positive number (m)",
                csv.display()
            )
        );
    }
    std::fs::write(&csv, "x,y,z,radius\n0,0,0,0.001\ninf,0,0,0.001\n").unwrap();
    let out = demcal().arg("heap-angle").arg(&csv).output().unwrap();
    assert_eq!(
        one_line_error(&out),
        format!(
            "error: {}: sphere 2: position (inf, 0, 0): expected finite numbers (m)",
            csv.display()
        )
    );
    std::fs::write(&csv, "x,y,z,radius\n0,0,0,0.001\n").unwrap();
    let out = demcal()
        .arg("heap-angle")
        .arg(&csv)
        .args(["--base", "nan"])
        .output()
        .unwrap();
    assert_eq!(
        one_line_error(&out),
        "error: --base NaN: expected a finite height (m)"
    );
    let mut c = demcal();
    c.arg("heap-angle")
        .arg(&csv)
        .args(["--planes", "1000000000"]);
    assert_eq!(
        one_line_error(&output_within(c, 20.0)),
        "error: --planes 1000000000: at most 180 (one per degree)"
    );
    let out = demcal()
        .arg("heap-angle")
        .arg(&csv)
        .args(["--axis", "0,inf"])
        .output()
        .unwrap();
    assert_eq!(
        one_line_error(&out),
        "error: --axis 0,inf: expected two finite numbers X,Y (m)"
    );
}

#[test]
fn doe_optimize_refuses_zero_solutions_and_a_nan_target() {
    let dir = temp_dir("doe-opt-bad");
    let data = dir.join("data.csv");
    std::fs::write(
        &data,
        "A,B,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,5\n0,0,3\n0,0,3.2\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let out = demcal()
            .args(["doe", "optimize"])
            .arg(&data)
            .args(["--response", "y", "--model", "linear"])
            .args(extra)
            .output()
            .unwrap();
        one_line_error(&out)
    };
    assert_eq!(
        run(&["--goal", "max", "--solutions", "0"]),
        "error: --solutions 0: expected at least 1"
    );
    assert_eq!(
        run(&["--goal", "target=nan"]),
        "error: --goal 'target=nan': target value is not a finite number"
    );
    assert_eq!(
        run(&["--goal", "max", "--starts", "100000000"]),
        "error: --starts 100000000: at most 10000 random starts"
    );
    let out = output_within(
        {
            let mut c = demcal();
            c.args([
                "doe",
                "design",
                "lhs",
                "--factors",
                "3",
                "--runs",
                "1000000000",
            ]);
            c
        },
        20.0,
    );
    assert_eq!(
        one_line_error(&out),
        "error: --runs 1000000000: at most 100000 runs"
    );
    // Refused before the spheres are drawn (1e8 reached 3.5 GB first).
    let out = output_within(
        {
            let mut c = demcal();
            c.args(["bench", "fill", "--count", "100000000"]);
            c
        },
        20.0,
    );
    assert_eq!(
        one_line_error(&out),
        "error: --count: expected 1 to 10000000, got 100000000"
    );
}

/// Without a terminal (a log file, a batch job), long runs still say how far they are: a plain
/// line every DEMCAL_PROGRESS_S seconds (default 5).
#[test]
fn long_runs_log_progress_when_not_on_a_terminal() {
    let dir = temp_dir("progress");
    let scene = write(&dir, SCENE);
    let out = demcal()
        .arg("simulate")
        .arg(&scene)
        .env("DEMCAL_PROGRESS_S", "0")
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let head = format!("{}: step ", scene.display());
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with(&head)).collect();
    assert!(lines.len() >= 2, "{err}");
    assert!(
        lines[0].contains(" %), t = ") && lines[0].contains(" s elapsed"),
        "{}",
        lines[0]
    );
    // The test command: the function test takes 0.3 s and reports as it goes.
    let test = dir.join("f.toml");
    std::fs::write(
        &test,
        "test = \"function\"\n[function]\nexpression = \"2*x\"\nvariables = { x = 1.0 }\nduration_s = 0.3\n",
    )
    .unwrap();
    let out = demcal()
        .arg("test")
        .arg(&test)
        .env("DEMCAL_PROGRESS_S", "0.05")
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let head = format!("{}: evaluate: t = ", test.display());
    assert!(
        err.lines().filter(|l| l.starts_with(&head)).count() >= 2,
        "{err}"
    );
    // A study: each running job reports, not only the finished runs.
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        slow_bowl()
            .replace(
                "plan = [\"screening\", \"steepest\", \"rsm\", \"optimize\", \"validate\"]",
                "plan = [{ stage = \"validate\", replicates = 1 }]",
            )
            .replace("duration_s = 0.2", "duration_s = 0.3"),
    )
    .unwrap();
    let out = demcal()
        .arg("run")
        .arg(&study)
        .env("DEMCAL_PROGRESS_S", "0.05")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.lines()
            .filter(
                |l| l.starts_with("stage 1/1 validate: job 1: run 1 (replicate 1): evaluate: t = ")
            )
            .count()
            >= 2,
        "{err}"
    );
}

/// `demcal run-one` runs a study's job file in its own process and writes the same record the
/// local executor stored for that run; a failed run's record carries its kind.
#[test]
fn run_one_executes_a_job_file_as_the_study_would() {
    let dir = temp_dir("run-one");
    let study_text = r#"
name = "bowl"
seed = 5
plan = [{ stage = "screening", design = "pb" }]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2)"
variables = { a = 0.8, b = 0.5 }
noise = 0.02
fail_when = "a + b - 2.0"

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.4
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.1
max = 0.9

[target]
value = 30.0
"#;
    let path = dir.join("bowl.toml");
    std::fs::write(&path, study_text).unwrap();
    run_ok(&["run".as_ref(), path.as_os_str()]);
    let study = study::Study::load(&path).unwrap();
    let store = study::Store::open(&study.store_path(), false).unwrap();
    let stored = store.runs().unwrap();
    let replay = study::replay(&study, &stored, None).unwrap();
    let stage = &replay.stages[0];
    let mut checked = (0, 0);
    for (spec, rec) in stage.runs.iter().zip(&stage.records) {
        let rec = rec.as_ref().expect("stored");
        let job = study::Job::new(&study, spec);
        let job_path = dir.join(format!("job{}.json", spec.index));
        std::fs::write(&job_path, job.to_json()).unwrap();
        let line = run_ok(&["run-one".as_ref(), job_path.as_os_str()]);
        let back: study::store::RunRecord = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("job{}.record.json", spec.index))).unwrap(),
        )
        .unwrap();
        assert_eq!(back.response, rec.response, "{line}");
        assert_eq!(back.fingerprint, rec.fingerprint);
        assert_eq!(back.status, rec.status);
        assert_eq!(back.error_kind, rec.error_kind);
        match rec.response {
            Some(_) => checked.0 += 1,
            None => {
                assert_eq!(rec.error_kind, Some(study::RunErrorKind::Diverged));
                assert!(line.contains("failed (diverged)"), "{line}");
                checked.1 += 1;
            }
        }
    }
    // Pb with a high half failing: some of each.
    assert!(checked.0 > 0 && checked.1 > 0, "{checked:?}");
    // A job whose output folder is not a run folder is refused before anything is cleared.
    let mut job = study::Job::new(&study, &stage.runs[0]);
    job.out_dir = dir.clone();
    let evil = dir.join("evil.json");
    std::fs::write(&evil, job.to_json()).unwrap();
    let out = demcal().arg("run-one").arg(&evil).output().unwrap();
    let e = one_line_error(&out);
    assert!(
        e.contains("evil.json: out_dir: expected a run folder named run<digits>"),
        "{e}"
    );
    assert!(path.exists(), "the study beside it is untouched");
    // A broken job file names the file and the key.
    let bad = dir.join("bad.json");
    std::fs::write(&bad, r#"{"tests": [], "seed": "three"}"#).unwrap();
    let out = demcal().arg("run-one").arg(&bad).output().unwrap();
    assert!(!out.status.success());
    let e = one_line_error(&out);
    assert!(e.contains("bad.json: seed: invalid type"), "{e}");
}

/// A path to something endless (/dev/zero) is refused before it is read, and a file past the
/// kind's limit after reading no more than the limit, where `demcal simulate /dev/zero` used to
/// reach 4.2 GB.
#[cfg(unix)]
#[test]
fn endless_files_are_refused_at_their_size_limit() {
    let dir = temp_dir("endless");
    let big = dir.join("big.toml");
    // Sparse: 17 MiB that take no disk.
    std::fs::File::create(&big)
        .unwrap()
        .set_len(17 << 20)
        .unwrap();
    for cmd in ["simulate", "test", "run"] {
        for (path, why) in [
            (Path::new("/dev/zero"), "not a plain file (a device)"),
            (big.as_path(), "larger than 16 MiB"),
        ] {
            let out = output_within(
                {
                    let mut c = demcal();
                    c.arg(cmd).arg(path);
                    c
                },
                20.0,
            );
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{cmd}");
            assert_eq!(err.lines().count(), 1, "{cmd}: {err}");
            assert!(
                err.contains(&path.display().to_string()) && err.contains(why),
                "{cmd}: {err}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
