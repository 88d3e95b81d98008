//! Why `demcal run` ended without finishing, typed where its caller acts on the difference: a
//! wrapper script or a scheduler retries a study whose store another process holds (exit 75),
//! a person fixes a study file (exit 2) or runs an interrupted study again (exit 130). The
//! message is the same one line either way. The bottom of the crate: it imports nothing of it.

/// Why `study::run` ended without finishing.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RunStudyError {
    /// The study file, a file it names, or a test it sets up is wrong: nothing ran.
    #[error("{0}")]
    StudyFile(String),
    /// Another `demcal run` of the study holds its store: nothing ran.
    #[error("{0}")]
    Locked(String),
    /// Ctrl-C: the finished runs are stored, and the same command goes on from them.
    #[error("{0}")]
    Interrupted(String),
    /// The study ran and a stage could not go on (too few runs finished, no model): the report
    /// is written and says why.
    #[error("{0}")]
    Stopped(String),
    /// The store, the report or an executor failed.
    #[error("{0}")]
    Other(String),
}

impl RunStudyError {
    /// The process exit status for it, as `demcal run` ends: 2 for a study to fix (as a usage
    /// error), 75 for a held store (`EX_TEMPFAIL`: try again later), 130 for Ctrl-C (as the
    /// shell reports SIGINT), 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            RunStudyError::StudyFile(_) => 2,
            RunStudyError::Locked(_) => 75,
            RunStudyError::Interrupted(_) => 130,
            RunStudyError::Stopped(_) | RunStudyError::Other(_) => 1,
        }
    }
}

impl From<String> for RunStudyError {
    fn from(message: String) -> Self {
        RunStudyError::Other(message)
    }
}

/// Why the store's lock could not be taken.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LockError {
    /// Another process runs the study.
    #[error("{0}")]
    Held(String),
    /// The lock file could not be made or written.
    #[error("{0}")]
    Io(String),
}

impl From<LockError> for RunStudyError {
    fn from(e: LockError) -> Self {
        match e {
            LockError::Held(m) => RunStudyError::Locked(m),
            LockError::Io(m) => RunStudyError::Other(m),
        }
    }
}
