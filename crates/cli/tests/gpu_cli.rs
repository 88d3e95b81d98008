//! `--backend gpu` and `backend = "gpu"` end to end: the same results as the CPU, a study that
//! resumes after a kill, and a clear fallback where there is no GPU. With
//! `DEMCAL_REQUIRE_GPU=1` (CI, with Mesa's lavapipe) the GPU must be there.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn demcal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_demcal"))
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demcal-gpu-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(out: Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Whether the GPU ran: without one the program says it runs on the CPU, which CI must not see.
fn check_gpu(stderr: &str) {
    let fell_back = stderr.contains("running on the CPU");
    if std::env::var("DEMCAL_REQUIRE_GPU").as_deref() == Ok("1") {
        assert!(!fell_back, "DEMCAL_REQUIRE_GPU=1 but: {stderr}");
    } else if fell_back {
        eprintln!("no GPU here; the fallback was checked instead: {stderr}");
    }
}

/// Equal to the CPU within `spread`: the GPU's segments sum each particle's contacts in another
/// order than the CPU (and a GPU compiler may fuse a multiply and an add), and a granular flow
/// grows round-off differences into a scatter of its results.
fn assert_close(what: &str, gpu: f64, cpu: f64, spread: f64) {
    assert!((gpu - cpu).abs() <= spread, "{what}: GPU {gpu}, CPU {cpu}");
}

fn field(line: &str, key: &str) -> f64 {
    line.split(' ')
        .find_map(|f| f.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("no {key} in {line}"))
        .parse()
        .unwrap()
}

/// 150 spheres poured into a cup, on either back end.
#[test]
fn simulate_on_the_gpu_gives_the_cpus_result() {
    let dir = temp_dir("simulate");
    let scene = dir.join("cup.toml");
    std::fs::write(
        &scene,
        r#"
[simulation]
duration = 0.02
time_step_percent = 20

[output]
directory = "out"

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
size = { type = "fixed", radius = 0.002 }
region = { type = "cylinder", base = [0.0, 0.0, 0.0], radius = 0.02, length = 0.05 }
fill = { type = "random", count = 150, seed = 4 }
"#,
    )
    .unwrap();
    let run = |backend: &str| {
        let out = demcal()
            .args(["simulate".as_ref(), scene.as_os_str()])
            .args(["--backend", backend])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        (ok(out), err)
    };
    let (cpu, _) = run("cpu");
    let (gpu, err) = run("gpu");
    check_gpu(&err);
    let (cpu, gpu) = (cpu.lines().last().unwrap(), gpu.lines().last().unwrap());
    assert_eq!(field(cpu, "steps"), field(gpu, "steps"));
    assert_close(
        "kinetic energy",
        field(gpu, "kinetic_energy_j"),
        field(cpu, "kinetic_energy_j"),
        0.05 * field(cpu, "kinetic_energy_j"),
    );
}

/// A small lifted-cylinder heap (250 spheres on a 0.2 m plate), the quickstart's test made small.
/// At 120 spheres on a 0.12 m plate some seeds left a flank flat or with two profile points,
/// which the heap measurement now refuses (issue 41), and at 200 one of this study's two seeds
/// still did; 250 on the wider plate measured at every seed tried (1-6 and the study's two).
const REPOSE: &str = r#"
test = "angle_of_repose"
seed = 1

[[material]]
name = "bead"
density = 1500
poisson_ratio = 0.3
shear_modulus = 5.0e6

[[material]]
name = "steel"
density = 7850
poisson_ratio = 0.3
shear_modulus = 7.0e10

[[interaction]]
materials = ["bead", "bead"]
restitution = 0.4
static_friction = 0.5
rolling_friction = 0.1

[[interaction]]
materials = ["bead", "steel"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.1

[angle_of_repose]
particles = { material = "bead", size = { type = "fixed", radius = 0.0025 } }
wall_material = "steel"
cylinder_diameter = 0.03
cylinder_height = 0.06
plate_size = 0.2
fill = { count = 250 }
lift_speed = 0.2
settle_speed = 0.05
"#;

fn study(dir: &Path, backend: &str) -> PathBuf {
    std::fs::write(dir.join("repose.toml"), REPOSE).unwrap();
    let path = dir.join("study.toml");
    std::fs::write(
        &path,
        format!(
            r#"name = "small heap"
seed = 5
test = "repose.toml"
backend = "{backend}"
plan = [{{ stage = "validate", replicates = 2 }}]

[[parameter]]
name = "static_friction"
path = "interaction[bead,bead].static_friction"
min = 0.4
max = 0.6

[target]
response = "angle_of_repose_deg"
value = 15
"#
        ),
    )
    .unwrap();
    path
}

/// (stage, run, response) of every stored run, sorted.
fn responses(dir: &Path) -> Vec<(String, String, String)> {
    let text = std::fs::read_to_string(dir.join("report/results.csv")).unwrap();
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (stage, run, response) = (col("stage"), col("run"), col("angle_of_repose_deg"));
    let mut rows: Vec<_> = r
        .records()
        .map(|row| {
            let row = row.unwrap();
            (
                row[stage].to_string(),
                row[run].to_string(),
                row[response].to_string(),
            )
        })
        .collect();
    rows.sort();
    rows
}

#[test]
fn a_gpu_study_killed_mid_way_resumes_and_matches_the_cpu() {
    let cpu_dir = temp_dir("study-cpu");
    let cpu = study(&cpu_dir, "cpu");
    ok(demcal()
        .args(["run".as_ref(), cpu.as_os_str()])
        .output()
        .unwrap());

    let dir = temp_dir("study-gpu");
    let path = study(&dir, "gpu");
    // One run at a time (on the GPU the default is the stage in one batch), so that the kill
    // falls between the two.
    let mut child = demcal()
        .args(["run".as_ref(), path.as_os_str()])
        .args(["--jobs", "1"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Kill once the first run is stored.
    let t0 = std::time::Instant::now();
    let mut stored = false;
    while t0.elapsed().as_secs() < 300 && !stored {
        std::thread::sleep(std::time::Duration::from_millis(200));
        if child.try_wait().unwrap().is_some() {
            break;
        }
        let out = demcal()
            .args(["status".as_ref(), path.as_os_str()])
            .output()
            .unwrap();
        stored = String::from_utf8_lossy(&out.stdout).contains(" 1 done");
    }
    let _ = child.kill();
    child.wait().unwrap();
    ok(demcal()
        .args(["report".as_ref(), path.as_os_str()])
        .output()
        .unwrap());
    let before = responses(&dir);

    // Resumed with the flag (the study's key says the same).
    let out = demcal()
        .args(["run".as_ref(), path.as_os_str()])
        .args(["--backend", "gpu"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    ok(out);
    check_gpu(&err);
    let after = responses(&dir);
    let want = responses(&cpu_dir);
    assert_eq!(after.len(), 2, "{after:?}");
    for row in &before {
        assert!(after.contains(row), "run lost or re-run: {row:?}");
    }
    let (mut gpu_angles, mut cpu_angles) = (Vec::new(), Vec::new());
    for (g, c) in after.iter().zip(&want) {
        assert_eq!((&g.0, &g.1), (&c.0, &c.1));
        // An empty response is a failed run: a heap of 120 spheres was small enough that some
        // seeds gave a profile too short to measure; at 250 every seed tried measures.
        let parse = |s: &str| {
            s.parse::<f64>()
                .unwrap_or_else(|_| panic!("run {} failed: {g:?} {c:?}", g.1))
        };
        gpu_angles.push(parse(&g.2));
        cpu_angles.push(parse(&c.2));
    }
    // A 250-sphere heap scatters by degrees from seed to seed (one GPU run gave 8.6° where the
    // CPU gave 13.7°), and the GPU's run is another draw of that scatter (the physics is checked
    // to round-off in crates/gpu/tests): the two runs' means are compared, within 5°, and every
    // heap must stand above 5°, which still catches a lost law (a heap without friction lies
    // below 5°).
    for a in &gpu_angles {
        assert!(
            *a > 5.0,
            "a GPU heap of {a}° (without friction?): {gpu_angles:?}"
        );
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert_close(
        "mean angle of repose",
        mean(&gpu_angles),
        mean(&cpu_angles),
        5.0,
    );

    // The same study with both runs in one batch (the GPU's default): the same numbers as one at
    // a time, since a simulation's result does not depend on its neighbours in a batch.
    let batched_dir = temp_dir("study-gpu-batch");
    let batched = study(&batched_dir, "gpu");
    let out = demcal()
        .args(["run".as_ref(), batched.as_os_str()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    ok(out);
    check_gpu(&err);
    if !err.contains("running on the CPU") {
        assert!(
            err.contains("(largest 2)"),
            "the runs were not batched: {err}"
        );
    }
    assert_eq!(responses(&batched_dir), after);
}

/// `demcal bench batch` on the CPU runner (its GPU side is the study above, batched): the line it
/// prints, and counts it refuses.
#[test]
fn bench_batch_prints_simulations_per_hour() {
    let dir = temp_dir("bench-batch");
    let test = dir.join("repose.toml");
    std::fs::write(&test, REPOSE).unwrap();
    let out = ok(demcal()
        .args(["bench", "batch", "--runs", "3", "--jobs", "2", "--test"])
        .arg(&test)
        .output()
        .unwrap());
    let line = out.lines().next().unwrap();
    assert!(
        line.starts_with("batch cpu: 3 runs of angle_of_repose (")
            && line.contains(" 2 at a time: "),
        "{line}"
    );
    let per_hour: f64 = line
        .split(" simulations per hour")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(per_hour > 0.0, "{line}");
    assert!(line.contains("(sd over 3 runs)"), "{line}");
    for bad in [["--runs", "0"], ["--jobs", "0"]] {
        let out = demcal()
            .args(["bench", "batch", "--test"])
            .arg(&test)
            .args(bad)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&format!("{} 0", bad[0])), "{err}");
    }
}

/// A bonded bar pulled apart (examples/stalks/bonded_bar.toml, faster and shorter): on the GPU its
/// bonds, grips and curve stay on the device between the curve's points, and the test gives the
/// CPU's curve, peak and breakages.
#[test]
fn a_bonded_tension_test_on_the_gpu_gives_the_cpus_curve() {
    let dir = temp_dir("bonded-bar");
    let example = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/stalks/bonded_bar.toml"),
    )
    .unwrap();
    let fast = example
        .replace("\nspeed = 0.02\n", "\nspeed = 0.1\n")
        .replace(
            "\nmax_displacement = 0.002\n",
            "\nmax_displacement = 0.0009\n",
        );
    assert_ne!(fast, example, "the example's speed and travel moved");
    let file = dir.join("bar.toml");
    std::fs::write(&file, fast).unwrap();
    let result = |backend: &str| -> serde_json::Value {
        let out = demcal()
            .arg("test")
            .arg(&file)
            .args(["--json", "--backend", backend])
            .output()
            .unwrap();
        if backend == "gpu" {
            check_gpu(&String::from_utf8_lossy(&out.stderr));
        }
        let text = ok(out);
        serde_json::from_str(text.lines().last().unwrap()).unwrap()
    };
    let (cpu, gpu) = (result("cpu"), result("gpu"));
    let number = |v: &serde_json::Value, key: &str| v[key].as_f64().unwrap();
    eprintln!(
        "bonded bar: CPU peak {} N, {} broken; GPU peak {} N, {} broken",
        cpu["peak_force_n"], cpu["bonds_broken"], gpu["peak_force_n"], gpu["bonds_broken"]
    );
    assert!(number(&cpu, "bonds_broken") > 0.0, "{cpu}");
    assert_eq!(cpu["bonds_broken"], gpu["bonds_broken"]);
    assert_eq!(cpu["bonds_broken_tension"], gpu["bonds_broken_tension"]);
    for key in [
        "peak_force_n",
        "mean_force_n",
        "stiffness_n_per_m",
        "displacement_at_peak_m",
        "work_j",
    ] {
        let (a, b) = (number(&cpu, key), number(&gpu, key));
        assert!((a - b).abs() <= 1e-9 * a.abs(), "{key}: GPU {b}, CPU {a}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
