//! The crate's error type. Every fallible public function returns [`Result`].
//!
//! Errors name what is wrong and where (file and line for malformed files, the field of
//! `model.toml`, the DoF index, the frequency of a singular pencil) and, where there is one,
//! the fix. Library code never panics on bad input (docs/design.md §4).

use std::path::PathBuf;

/// Everything that can go wrong in sparsemor.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A file is malformed; `line` is 1-based (0 when the problem is not tied to a line).
    #[error("{}:{line}: {msg}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number, 0 if not tied to a line.
        line: usize,
        /// What is wrong and how to fix it.
        msg: String,
    },
    /// A model (matrices, nodes, DoF indices, damping) violates docs/design.md §1/§4.
    #[error("invalid model: {0}")]
    InvalidModel(String),
    /// A setting (scene, band, frequencies, interface, thread count, ...) is impossible.
    #[error("invalid setting: {0}")]
    InvalidSetting(String),
    /// A DoF index is outside 0..N (a scene, interface or retained-DoF list).
    #[error("invalid setting: {what}: DoF {dof} is out of range (the model has DoFs 0..{})", n.saturating_sub(1))]
    DofOutOfRange {
        /// The list it came from ("inputs", "interface", ...).
        what: String,
        /// The offending index.
        dof: usize,
        /// N.
        n: usize,
    },
    /// The least-squares fit of eq. 22 has fewer rows 2pz than unknowns per row n.
    #[error(
        "invalid setting: 2pz = {rows} < n = {order}: the least-squares fit of eq. 22 is underdetermined; \
         use at least {min_frequencies} reference frequencies or a smaller interface"
    )]
    Underdetermined {
        /// 2pz: twice the inputs times the reference frequencies.
        rows: usize,
        /// n: the interface size (ROM order).
        order: usize,
        /// The smallest number of reference frequencies z with 2pz ≥ n.
        min_frequencies: usize,
    },
    /// A factorization is numerically singular or inaccurate at a frequency (docs/design.md §3.1).
    #[error("A(s) at {freq_hz} Hz is numerically singular: {detail}")]
    Singular {
        /// The frequency of the failing pencil.
        freq_hz: f64,
        /// Measured evidence (probe error, pivot ratio) and what would help.
        detail: String,
    },
    /// A factorization backend failed for another reason (allocation, library status).
    #[error("factorization failed: {0}")]
    Factor(String),
    /// An iteration (the eigensolver's Krylov–Schur, ARPACK) stopped before every wanted
    /// quantity converged: what converged, the largest residual, where, and what to change.
    #[error("not converged: {0}")]
    NotConverged(String),
    /// Another MPI rank failed (docs/design.md §9): its rank and its error's message.
    #[error("rank {rank}: {message}")]
    Remote {
        /// The rank that failed.
        rank: usize,
        /// Its error, as text.
        message: String,
    },
    /// The ranks of a distributed run could not work together (a malformed message, a
    /// command run by only some ranks).
    #[error("distributed run: {0}")]
    Distributed(String),
    /// The work was cancelled through the progress callback.
    #[error("cancelled by the caller")]
    Cancelled,
}

/// `Result` with the crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// True for every impossible-setting error: [`Error::InvalidSetting`] and its structured
    /// forms [`Error::DofOutOfRange`] and [`Error::Underdetermined`].
    pub fn is_invalid_setting(&self) -> bool {
        matches!(
            self,
            Error::InvalidSetting(_) | Error::DofOutOfRange { .. } | Error::Underdetermined { .. }
        )
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// A parse error at `path:line`.
    pub fn parse(path: impl Into<PathBuf>, line: usize, msg: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            line,
            msg: msg.into(),
        }
    }
}
