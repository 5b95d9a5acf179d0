//! Interruption (Ctrl-C: SIGINT; SIGTERM, SIGHUP): one line on stderr
//! saying what was written, exit status 130, and never a half-written or
//! mixed output.
//!
//! Every write of an output ([`crate::outdir::write_folder`],
//! [`crate::outdir::write::write_atomic`]) runs under the commit lock
//! ([`commit`]): from the creation of its staging folder or temporary file
//! to the final rename. The handler ([`install`]) takes the same lock, so
//! it waits for a write in progress to end (renamed in, whole) and no write
//! starts after it: the process then exits with no staging folder nor
//! temporary file left, and the handler names the outputs already in place
//! ([`kept`]), or says `interrupted: nothing written`.
//!
//! A command that writes several files which belong together (`roks
//! render`: the EXR and its PNG preview; `roks fit-model`: the JSON, the
//! plot and the OpticStudio text) holds one [`commit`] guard around all of
//! them: an interrupt then keeps all of them or none. The guard is
//! reentrant within a thread.

//!
//! In-process runs (the library API, the Python module) are not ended by
//! a signal: they carry a [`Cancel`] token, which the photon loops check
//! between batches ([`cancelled`]), and the run then ends with nothing
//! written.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

/// The exit status of an interrupted run (128 + SIGINT, as shells report it).
pub const EXIT_STATUS: u8 = 130;

/// Held while an output is written and renamed into place.
static LOCK: Mutex<()> = Mutex::new(());

/// The outputs in place so far (paths as given), for the handler's line.
static KEPT: Mutex<Vec<String>> = Mutex::new(Vec::new());

thread_local! {
    /// This thread's hold on [`LOCK`] and its depth (the guard is reentrant).
    static HELD: RefCell<(usize, Option<MutexGuard<'static, ()>>)> =
        const { RefCell::new((0, None)) };
}

/// The commit lock, held until the guard is dropped (reentrant: a nested
/// guard of the same thread only counts).
#[must_use = "the lock is released when the guard is dropped"]
pub struct Commit(());

/// Take the commit lock for the writes and renames of one output (or of
/// several that belong together): an interrupt waits for it.
pub fn commit() -> Commit {
    HELD.with(|h| {
        let mut h = h.borrow_mut();
        if h.0 == 0 {
            h.1 = Some(LOCK.lock().unwrap_or_else(PoisonError::into_inner));
        }
        h.0 += 1;
    });
    Commit(())
}

impl Drop for Commit {
    fn drop(&mut self) {
        HELD.with(|h| {
            let mut h = h.borrow_mut();
            h.0 -= 1;
            if h.0 == 0 {
                h.1 = None;
            }
        });
    }
}

/// Note that `what` (a path, as the user gave it) is now in place: an
/// interrupt after this says it was kept.
pub fn kept(what: String) {
    KEPT.lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push(what);
}

/// The line an interrupt prints: `interrupted: nothing written`, or
/// `interrupted: kept A, B (written before the interrupt); nothing else
/// written`.
#[must_use]
pub fn message(kept: &[String]) -> String {
    if kept.is_empty() {
        "interrupted: nothing written".to_owned()
    } else {
        format!(
            "interrupted: kept {} (written before the interrupt); nothing else written",
            kept.join(", ")
        )
    }
}

/// Install the handler of SIGINT, SIGTERM and SIGHUP (Unix; Ctrl-C and
/// Ctrl-Break elsewhere): wait for any write in progress, print
/// `roks: ` and [`message`] on stderr, exit with [`EXIT_STATUS`].
///
/// # Errors
/// The handler cannot be installed (the signal handling crate's message).
pub fn install() -> Result<(), String> {
    ctrlc::set_handler(|| {
        // Held until exit: no write starts after this.
        let _held = LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        let kept = KEPT.lock().unwrap_or_else(PoisonError::into_inner).clone();
        // A progress bar may be on the terminal's current line.
        let clear = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            "\r\x1b[2K"
        } else {
            ""
        };
        // One line, whatever a path holds.
        let line: String = message(&kept)
            .chars()
            .flat_map(|c| {
                if c.is_control() {
                    c.escape_default().collect::<Vec<_>>()
                } else {
                    vec![c]
                }
            })
            .collect();
        eprintln!("{clear}roks: {line}");
        std::process::exit(i32::from(EXIT_STATUS));
    })
    .map_err(|e| e.to_string())
}

/// A cancel token of an in-process run: clones share one flag; once
/// [`cancel`](Self::cancel)led, the run's photon loops stop between batches
/// of [`crate::tally::sum::BATCH`] photons (well under a second), and the
/// run ends with an error, writing nothing.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not cancelled yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Ask the run to stop (from any thread).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`cancel`](Self::cancel) was called.
    #[must_use]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

thread_local! {
    /// The token of the run this thread works for (the workers of a run's
    /// own thread pool: [`watch`]).
    static CURRENT: RefCell<Option<Cancel>> = const { RefCell::new(None) };
}

/// Make `token` the one this thread's work checks ([`cancelled`]); called
/// when a run's own worker thread starts.
pub fn watch(token: Option<Cancel>) {
    CURRENT.with(|c| *c.borrow_mut() = token);
}

/// Whether the run this thread works for was cancelled (never, for a
/// thread without a token: the command line's).
#[must_use]
pub fn cancelled() -> bool {
    CURRENT.with(|c| c.borrow().as_ref().is_some_and(Cancel::is_cancelled))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_says_what_was_kept() {
        assert_eq!(message(&[]), "interrupted: nothing written");
        assert_eq!(
            message(&["a.exr".into(), "a.png".into()]),
            "interrupted: kept a.exr, a.png (written before the interrupt); nothing else written"
        );
    }

    #[test]
    fn the_guard_is_reentrant() {
        let outer = commit();
        let inner = commit();
        drop(inner);
        // Still held by this thread: another thread cannot take it.
        assert!(LOCK.try_lock().is_err());
        drop(outer);
        assert!(LOCK.try_lock().is_ok());
    }
}
