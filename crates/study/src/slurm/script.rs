//! The batch script of a job array: the user's `[executor]` settings as `#SBATCH` lines, the
//! environment (modules, a sourced script), then `demcal run-one` on the job file named by the
//! task's line of the array's task list. The array, job name and log go on sbatch's command line,
//! so the script holds only what the user chose and can be read (or resubmitted) as it is.

use std::fmt::Write;
use std::path::Path;

use super::settings::SlurmSettings;

/// A word for bash, in single quotes where it needs them.
pub fn quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The script for an array whose task `i` runs the job file on line `i + 1` of `tasks`.
pub fn batch_script(
    s: &SlurmSettings,
    gpus: usize,
    what: &str,
    tasks: &Path,
    demcal: &Path,
) -> String {
    let mut t = String::new();
    // Modules are set up by the login shell's profile on most clusters.
    t.push_str(if s.modules.is_empty() {
        "#!/bin/bash\n"
    } else {
        "#!/bin/bash -l\n"
    });
    writeln!(t, "# Written by demcal: {what}.").unwrap();
    t.push_str(
        "# Task i of the array makes the run whose job file is on line i + 1 of the task list.\n",
    );
    writeln!(t, "#SBATCH --ntasks=1").unwrap();
    writeln!(t, "#SBATCH --cpus-per-task={}", s.cpus_per_run).unwrap();
    for (option, value) in [
        ("partition", &s.partition),
        ("account", &s.account),
        ("qos", &s.qos),
        ("time", &s.time_limit),
        ("mem", &s.memory),
    ] {
        if let Some(v) = value {
            writeln!(t, "#SBATCH --{option}={v}").unwrap();
        }
    }
    if gpus > 0 {
        writeln!(t, "#SBATCH --gres=gpu:{gpus}").unwrap();
    }
    for line in &s.sbatch_lines {
        writeln!(t, "#SBATCH {line}").unwrap();
    }
    // Module names are checked when the study is read (letters, digits, / . _ + - : and spaces).
    for m in &s.modules {
        writeln!(t, "module load {m}").unwrap();
    }
    if let Some(env) = &s.environment_script {
        writeln!(t, "source {}", quote(&env.display().to_string())).unwrap();
    }
    // Strict only from here: site scripts and conda's activate often read unset variables.
    t.push_str("set -u\n");
    let tasks = quote(&tasks.display().to_string());
    writeln!(
        t,
        "task=${{SLURM_ARRAY_TASK_ID:?demcal: not an array task}}"
    )
    .unwrap();
    writeln!(t, "job=$(sed -n \"$((task + 1))p\" {tasks})").unwrap();
    // The path as printf's argument, never inside double quotes where $ and ` would expand.
    writeln!(
        t,
        "if [ -z \"$job\" ]; then printf 'demcal: array task %s has no line in %s\\n' \"$task\" {tasks} >&2; exit 2; fi"
    )
    .unwrap();
    writeln!(
        t,
        "exec {} run-one \"$job\" --threads {}",
        quote(&demcal.display().to_string()),
        s.cpus_per_run
    )
    .unwrap();
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn the_script_carries_every_setting() {
        let s = SlurmSettings {
            partition: Some("compute".into()),
            account: Some("agri".into()),
            qos: Some("normal".into()),
            time_limit: Some("2:00:00".into()),
            cpus_per_run: 4,
            memory: Some("8G".into()),
            sbatch_lines: vec!["--constraint=skylake".into()],
            modules: vec!["gcc/12".into()],
            environment_script: Some(PathBuf::from("/home/me/my env.sh")),
            ..SlurmSettings::default()
        };
        let text = batch_script(
            &s,
            1,
            "study x, stage 1",
            Path::new("/runs/stage1/array-ab.tasks"),
            Path::new("/opt/demcal"),
        );
        for line in [
            "#!/bin/bash -l",
            "#SBATCH --cpus-per-task=4",
            "#SBATCH --partition=compute",
            "#SBATCH --account=agri",
            "#SBATCH --qos=normal",
            "#SBATCH --time=2:00:00",
            "#SBATCH --mem=8G",
            "#SBATCH --gres=gpu:1",
            "#SBATCH --constraint=skylake",
            "module load gcc/12",
            "source '/home/me/my env.sh'",
            "job=$(sed -n \"$((task + 1))p\" /runs/stage1/array-ab.tasks)",
            "exec /opt/demcal run-one \"$job\" --threads 4",
        ] {
            assert!(text.lines().any(|l| l == line), "no line {line} in\n{text}");
        }
        assert_eq!(quote("it's"), "'it'\\''s'");
    }
}
