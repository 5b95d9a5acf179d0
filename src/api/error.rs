//! Why a call of the library API fails: one typed error whose `Display` is
//! the one-line message the command line prints (naming the option, or the
//! scene file and key), and whether it is bad input or a failed write.

use std::path::PathBuf;

use crate::scene::SceneError;

/// Why a call of the library API ([`crate::api`]) fails. Every variant
/// but [`Error::Io`] and [`Error::Interrupted`] is bad input (`roks` exits with status 2); its
/// `Display` is one line, word for word the command line's message.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene file (or a result folder read back): the file, the key and
    /// what is wrong.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A value set by a command-line option (or its library equivalent)
    /// that the option's checks refuse: `OPTION: MESSAGE`.
    #[error("{option}: {message}")]
    Option {
        /// The option, e.g. `--shard`.
        option: &'static str,
        /// What is wrong, e.g. the scene loader's message for the key it
        /// overrides.
        message: String,
    },
    /// A scene's key refused in the light of an option, or a photon that
    /// met what the scene left undefined: the whole line, naming the scene
    /// file and key.
    #[error("{0}")]
    Input(String),
    /// A render's settings, camera or preview ([`crate::render::RenderError`]).
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// A render refused before or after it ran ([`crate::render::job::JobError`]).
    #[error(transparent)]
    RenderJob(#[from] crate::render::job::JobError),
    /// A result folder that cannot be written where asked.
    #[error("{}: {error}", .path.display())]
    Out {
        /// The folder.
        path: PathBuf,
        /// Why.
        error: crate::outdir::OutPathError,
    },
    /// Anything else: reading or writing files (not bad input).
    #[error(transparent)]
    Io(#[from] anyhow::Error),
    /// An in-process run stopped by its cancel token
    /// ([`crate::api::Control`]): nothing was written.
    #[error("interrupted: nothing written")]
    Interrupted,
}

impl Error {
    /// `message` refused at `option`.
    pub(crate) fn option(option: &'static str, message: impl std::fmt::Display) -> Self {
        Self::Option {
            option,
            message: message.to_string(),
        }
    }

    /// Whether this is bad input (exit status 2), not a failed read or
    /// write (exit status 1).
    #[must_use]
    pub fn is_input(&self) -> bool {
        !matches!(self, Self::Io(_) | Self::Interrupted)
    }
}

/// An output refused (bad input) or a failed write ([`Error::Io`]).
impl From<crate::outdir::check::OutputError> for Error {
    fn from(e: crate::outdir::check::OutputError) -> Self {
        use crate::outdir::check::OutputError;
        match e {
            OutputError::Refused(m) => Self::Input(m),
            OutputError::Write(m) => Self::Io(anyhow::Error::msg(m)),
        }
    }
}
