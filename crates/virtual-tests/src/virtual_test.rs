//! What a virtual test is: a name, its settings, a run that gives an outcome, and from the
//! outcome its responses (what a study can calibrate against), a summary line and pictures.
//!
//! A test implements [`VirtualTest`] with its own settings and outcome types; every
//! `VirtualTest` is also a [`Registered`] test, the form the registry ([`crate::registry`]) keeps
//! and `demcal test`, the study runner and the CLI help use: it reads the settings from a test
//! file (errors naming the key), checks them, runs, and turns the outcome into JSON (the keys of
//! `demcal test --json`), responses, summary and pictures.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::file::TestFile;

/// A measured response: a number, or a curve (force against displacement, say).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum Response {
    Scalar(f64),
    Curve {
        x_name: String,
        x_unit: String,
        y_name: String,
        y_unit: String,
        x: Vec<f64>,
        y: Vec<f64>,
    },
}

/// Why a run gave no outcome, typed so that a study can tell a bad setting from a diverged
/// simulation. Each holds the one-line message (naming the file and the key where there is one).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TestError {
    /// The settings, or the scene they make, were refused (before or while building).
    #[error("{0}")]
    Settings(String),
    /// The simulation blew up: positions or velocities not finite.
    #[error("{0}")]
    Diverged(String),
    /// A particle left the simulation domain.
    #[error("{0}")]
    Escaped(String),
    /// The run finished but the measurement could not be made (or its pictures not written).
    #[error("{0}")]
    Measurement(String),
    /// The progress callback stopped the run (an interrupt, a time limit): its message.
    #[error("{0}")]
    Stopped(String),
    /// The run's files could not be written (permission denied, disk full, ...): a fault of the
    /// machine, not of the parameters, so a study makes the run again once it is fixed.
    #[error("{0}")]
    Output(String),
}

impl TestError {
    /// The one-line message.
    pub fn message(&self) -> &str {
        match self {
            TestError::Settings(m)
            | TestError::Diverged(m)
            | TestError::Escaped(m)
            | TestError::Measurement(m)
            | TestError::Stopped(m)
            | TestError::Output(m) => m,
        }
    }
}

/// Untyped errors inside a test's run come from setting it up (the scene its settings make, a
/// geometry it looks for): measurement failures and stops are typed where they happen.
impl From<String> for TestError {
    fn from(m: String) -> Self {
        TestError::Settings(m)
    }
}

impl From<TestError> for String {
    fn from(e: TestError) -> Self {
        e.to_string()
    }
}

/// A picture a test draws of its outcome, written under `file_name` when asked for.
#[derive(Clone, Debug)]
pub struct Picture {
    pub file_name: String,
    pub bytes: Vec<u8>,
}

/// What a run is given: the seed, where pictures go (when they are wanted), and the progress
/// callback, which hears the phase and the simulated time and stops the run by returning an
/// error (an interrupted study, a run over its time limit).
pub struct Run<'a> {
    pub seed: u64,
    pub out: Option<&'a Path>,
    progress: &'a mut dyn FnMut(&str, f64) -> Result<(), String>,
}

impl<'a> Run<'a> {
    pub fn new(
        seed: u64,
        out: Option<&'a Path>,
        progress: &'a mut dyn FnMut(&str, f64) -> Result<(), String>,
    ) -> Run<'a> {
        Run {
            seed,
            out,
            progress,
        }
    }

    /// Reports `phase` at simulated time `t`; an error means stop now.
    pub fn progress(&mut self, phase: &str, t: f64) -> Result<(), String> {
        (self.progress)(phase, t)
    }
}

/// One virtual lab test.
pub trait VirtualTest: Sync {
    /// The table of the test file named after the test (serde, `deny_unknown_fields`).
    type Settings: DeserializeOwned;
    /// Everything the run measured; serialised, it is the JSON `demcal test --json` prints.
    type Outcome: Serialize;

    /// The name a test file gives as `test = "..."`.
    fn name(&self) -> &'static str;
    /// A few words for help texts: the set-up.
    fn about(&self) -> &'static str;
    /// Whether it simulates particles (and so needs `[[material]]` and `[[interaction]]`).
    fn needs_materials(&self) -> bool {
        true
    }
    /// The names of its responses, the usual one first.
    fn response_names(&self) -> &'static [&'static str];
    /// Checks the settings before anything is built; errors name the key
    /// ([`TestFile::error`]).
    fn check(&self, file: &TestFile, settings: &Self::Settings) -> Result<(), String>;
    /// Builds the scene the run starts from, as the run would (materials, geometry, placement,
    /// overlaps), and drops it: what a study checks before its first run. Tests without a scene
    /// keep the default.
    fn check_scene(
        &self,
        file: &TestFile,
        settings: &Self::Settings,
        seed: u64,
    ) -> Result<(), String> {
        let _ = (file, settings, seed);
        Ok(())
    }
    /// Builds the set-up, drives it and measures.
    fn run(
        &self,
        file: &TestFile,
        settings: &Self::Settings,
        run: &mut Run,
    ) -> Result<Self::Outcome, TestError>;
    /// The responses of an outcome, by name, in the order of [`VirtualTest::response_names`]
    /// (an optional one the settings did not ask for, as the `function` test's curve, is left out).
    fn responses(&self, outcome: &Self::Outcome) -> Vec<(&'static str, Response)>;
    /// One line saying what was measured.
    fn summary(&self, outcome: &Self::Outcome) -> String;
    /// Why the outcome must not be used as a measurement although the run finished (a
    /// mechanical test that was not quasi-static); a study stores such a run as failed.
    fn rejected(&self, _outcome: &Self::Outcome) -> Option<String> {
        None
    }
    /// Pictures of the outcome (drawn only when they will be written).
    fn pictures(&self, _outcome: &Self::Outcome) -> Result<Vec<Picture>, String> {
        Ok(Vec::new())
    }
    /// The sections of its table with the keys each accepts, as `docs/reference.md` heads them,
    /// so that the reference is checked against the code: by default the settings' fields under
    /// `[<name>]`. A test whose settings nest tables, or flatten a struct (whose keys serde does
    /// not list), names them itself.
    fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)> {
        vec![(
            format!("[{}]", self.name()),
            dem::keys::of::<Self::Settings>(),
        )]
    }
    /// The settings with every default filled in, as TOML, for a report's table of what a study
    /// holds fixed; None for a test that does not give them (the file's own table is shown).
    fn settings_value(&self, _settings: &Self::Settings) -> Option<toml::Value> {
        None
    }
}

/// A finished run, whatever the test.
#[derive(Clone, Debug)]
pub struct Finished {
    /// The outcome as JSON.
    pub json: serde_json::Value,
    pub summary: String,
    pub responses: Vec<(&'static str, Response)>,
    /// Empty unless the run was given a folder for them.
    pub pictures: Vec<Picture>,
    /// Why the outcome is not a valid measurement ([`VirtualTest::rejected`]).
    pub rejected: Option<String>,
}

/// A virtual test as the registry keeps it (any [`VirtualTest`] is one).
pub trait Registered: Sync {
    fn name(&self) -> &'static str;
    fn about(&self) -> &'static str;
    fn needs_materials(&self) -> bool;
    fn response_names(&self) -> &'static [&'static str];
    /// Reads and checks the file's settings without building anything.
    fn check_file(&self, file: &TestFile) -> Result<(), String>;
    /// Reads and checks the settings and builds the starting scene, without running.
    fn check_scene_file(&self, file: &TestFile, seed: u64) -> Result<(), String>;
    /// Reads and checks the settings, runs, and gives the outcome in every form.
    fn run_file(&self, file: &TestFile, run: &mut Run) -> Result<Finished, TestError>;
    /// See [`VirtualTest::reference_sections`].
    fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)>;
    /// The file's settings with the test's defaults filled in ([`VirtualTest::settings_value`]).
    fn full_settings(&self, file: &TestFile) -> Option<toml::Value>;
}

impl<T: VirtualTest> Registered for T {
    fn name(&self) -> &'static str {
        VirtualTest::name(self)
    }

    fn about(&self) -> &'static str {
        VirtualTest::about(self)
    }

    fn needs_materials(&self) -> bool {
        VirtualTest::needs_materials(self)
    }

    fn response_names(&self) -> &'static [&'static str] {
        VirtualTest::response_names(self)
    }

    fn check_file(&self, file: &TestFile) -> Result<(), String> {
        let settings: T::Settings = file.settings()?;
        self.check(file, &settings)
    }

    fn reference_sections(&self) -> Vec<(String, Vec<&'static str>)> {
        VirtualTest::reference_sections(self)
    }

    fn check_scene_file(&self, file: &TestFile, seed: u64) -> Result<(), String> {
        let settings: T::Settings = file.settings()?;
        self.check(file, &settings)?;
        self.check_scene(file, &settings, seed)
    }

    fn full_settings(&self, file: &TestFile) -> Option<toml::Value> {
        let settings: T::Settings = file.settings().ok()?;
        self.settings_value(&settings)
    }

    fn run_file(&self, file: &TestFile, run: &mut Run) -> Result<Finished, TestError> {
        let settings: T::Settings = file.settings()?;
        self.check(file, &settings)?;
        let outcome = self.run(file, &settings, run)?;
        let json = serde_json::to_value(&outcome).map_err(|e| {
            TestError::Measurement(format!("{}: cannot write the outcome: {e}", file.name))
        })?;
        let pictures = match run.out {
            Some(_) => self.pictures(&outcome).map_err(TestError::Measurement)?,
            None => Vec::new(),
        };
        Ok(Finished {
            json,
            rejected: self.rejected(&outcome),
            summary: self.summary(&outcome),
            responses: self.responses(&outcome),
            pictures,
        })
    }
}
