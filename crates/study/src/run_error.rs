//! Why a run gave no result: a kind that code can tell apart and a message for people. Stored
//! with each failed run (`store`), made by the job that ran it (`job`).

use serde::{Deserialize, Serialize};

/// Why a run gave no result.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunErrorKind {
    /// Stopped by Ctrl-C (never stored: the run is made again next time).
    Interrupted,
    /// Ran longer than the study's `run_time_limit_s`, or than its Slurm time limit.
    TimeLimit,
    /// The simulation blew up (non-finite positions or velocities).
    Diverged,
    /// A particle left the simulation domain.
    Escaped,
    /// The test's settings (with the run's values) were refused.
    BadSettings,
    /// The simulation ran but the measurement could not be made, or gave no finite response.
    MeasurementFailed,
    /// The run finished but was not quasi-static (a mechanical test whose specimen's kinetic
    /// energy exceeded its limit share of the work): inertia shows in its curve.
    NotQuasiStatic,
    /// The code panicked (a bug: the message says where).
    Panic,
    /// The cluster's scheduler ended the run's task without a result: memory limit, cancelled,
    /// node failure or pre-emption after its retries, an error starting it. (Its time limit is
    /// `TimeLimit`.)
    Cluster,
    /// The run's files could not be written (permission denied, disk full, ...): a fault of the
    /// machine, not a verdict on the parameters. Made again by the next `demcal run`.
    OutputFailed,
    /// Stored by a demcal version that did not record kinds.
    Unknown,
}

impl RunErrorKind {
    pub fn as_str(self) -> &'static str {
        match self {
            RunErrorKind::Interrupted => "interrupted",
            RunErrorKind::TimeLimit => "time_limit",
            RunErrorKind::Diverged => "diverged",
            RunErrorKind::Escaped => "escaped",
            RunErrorKind::BadSettings => "bad_settings",
            RunErrorKind::MeasurementFailed => "measurement_failed",
            RunErrorKind::NotQuasiStatic => "not_quasi_static",
            RunErrorKind::Panic => "panic",
            RunErrorKind::Cluster => "cluster",
            RunErrorKind::OutputFailed => "output_failed",
            RunErrorKind::Unknown => "unknown",
        }
    }

    /// A failure of the machine, not of the parameters: its files could not be written, or
    /// the cluster ended it (out of memory, cancelled, its node lost after every retry). Such
    /// runs are stored, so the report shows them, and made again by the next `demcal run`.
    pub fn is_transient(self) -> bool {
        matches!(self, RunErrorKind::OutputFailed | RunErrorKind::Cluster)
    }

    /// The kinds `is_transient` names, as stored.
    pub fn transient() -> Vec<RunErrorKind> {
        Self::all()
            .into_iter()
            .filter(|k| k.is_transient())
            .collect()
    }

    fn all() -> [RunErrorKind; 10] {
        [
            RunErrorKind::Interrupted,
            RunErrorKind::TimeLimit,
            RunErrorKind::Diverged,
            RunErrorKind::Escaped,
            RunErrorKind::BadSettings,
            RunErrorKind::MeasurementFailed,
            RunErrorKind::NotQuasiStatic,
            RunErrorKind::Panic,
            RunErrorKind::Cluster,
            RunErrorKind::OutputFailed,
        ]
    }

    /// The kind stored as `s` (`unknown` for anything else).
    pub fn from_stored(s: &str) -> RunErrorKind {
        Self::all()
            .into_iter()
            .find(|k| k.as_str() == s)
            .unwrap_or(RunErrorKind::Unknown)
    }
}

/// A run that gave no result: its kind and a one-line message.
#[derive(Clone, Debug, PartialEq)]
pub struct RunError {
    pub kind: RunErrorKind,
    pub message: String,
}

impl RunError {
    pub fn new(kind: RunErrorKind, message: impl Into<String>) -> Self {
        RunError {
            kind,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for RunError {}

impl From<virtual_tests::TestError> for RunError {
    fn from(e: virtual_tests::TestError) -> Self {
        use virtual_tests::TestError as T;
        let kind = match &e {
            T::Settings(_) => RunErrorKind::BadSettings,
            T::Diverged(_) => RunErrorKind::Diverged,
            T::Escaped(_) => RunErrorKind::Escaped,
            T::Measurement(_) => RunErrorKind::MeasurementFailed,
            T::Output(_) => RunErrorKind::OutputFailed,
            // The study's progress callback records why it stopped a run; this is the fallback.
            T::Stopped(_) => RunErrorKind::Interrupted,
        };
        RunError::new(kind, e.to_string())
    }
}
