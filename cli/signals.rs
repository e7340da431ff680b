//! Ctrl-C and SIGTERM during a render (one image or an animation's frames): the render stops at its
//! next step and writes what it has; a second signal (a second or more after the first: signals
//! together are one request), or a minute without stopping, exits at once.

use caustica::Renderer;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// Exit status of a render that a signal stopped: the image so far was written, but the render is not
/// what was asked for (128 + SIGINT, as shells report it).
pub const INTERRUPTED_EXIT: i32 = 130;

/// How long a stopping render may take to finish its paths and write its image: far more than a
/// step and the largest write take.
const STOP_GRACE: std::time::Duration = std::time::Duration::from_secs(60);

/// Whether a signal came: the process's own record, apart from the renderer's flag, which a frame's
/// restart lowers (`--frames` lost a signal that came between two frames' renders, and a second one
/// then did not exit either: the frames went on for the minute of grace). Raised, as the renderer's
/// flag is, once the signal has been acknowledged on stderr.
static STOPPING: AtomicBool = AtomicBool::new(false);

/// Signals received: the second exits at once.
static RECEIVED: AtomicU32 = AtomicU32::new(0);

/// When the first signal came.
static FIRST: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();

/// Signals this close after the first are the same request: `timeout` and a terminal's job control
/// signal the process and then its group, a moment apart, and the second read as "quit now" lost
/// the image and the checkpoint that the first was stopping to write.
const TOGETHER: std::time::Duration = std::time::Duration::from_millis(1000);

/// Whether SIGINT or SIGTERM has come since [`watch_for_signals`].
pub(crate) fn signalled() -> bool {
    STOPPING.load(Ordering::SeqCst)
}

/// SIGINT and SIGTERM raise the renderer's interrupt flag: the render stops at its next step and the
/// image so far is written. A second signal exits at once.
pub(crate) fn watch_for_signals(renderer: &Renderer) {
    let flag = renderer.interrupt_flag();
    let result = ctrlc::set_handler(move || {
        if RECEIVED.fetch_add(1, Ordering::SeqCst) > 0 {
            if FIRST.get().is_some_and(|first| first.elapsed() < TOGETHER) {
                return;
            }
            say("\nstopped at once: nothing more is written (what was written stays)");
            // A write cut short leaves no partial file beside its output (the previous file stays).
            caustica::film::partial::remove_all_and_exit(INTERRUPTED_EXIT);
        }
        FIRST.get_or_init(std::time::Instant::now);
        // Said before the render is told: told first, a small render wrote its image and exited
        // before the line was written, and the stop went unexplained.
        say("\nstopping: finishing the paths in flight and writing the image so far (again to quit now)");
        STOPPING.store(true, Ordering::SeqCst);
        flag.store(true, Ordering::SeqCst);
        // A render that cannot reach its next step (a path that never ends) would ignore the signal
        // for ever: a supervisor's SIGTERM (a test runner's time limit, a batch system) must still
        // end the process.
        std::thread::spawn(|| {
            std::thread::sleep(STOP_GRACE);
            say(&format!(
                "did not stop within {} s of the signal: exiting, nothing more is written",
                STOP_GRACE.as_secs()
            ));
            caustica::film::partial::remove_all_and_exit(INTERRUPTED_EXIT);
        });
    });
    if let Err(e) = result {
        tracing::warn!("cannot watch for Ctrl-C: {e}; an interrupted render will not write its image");
    }
}

/// A line on stderr, or nothing when stderr is gone (the parent that read it was killed):
/// `eprintln!` would panic there and take the signal handler's thread with it.
fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// A write past the file size limit (`ulimit -f`) raises SIGXFSZ, whose default action kills the
/// process mid-write and leaves the temporary file beside the output. Handled (by a flag nobody
/// reads), the write fails with "File too large" instead, its temporary file is removed, and the
/// failure is reported as a full disk's is.
pub(crate) fn writes_fail_past_the_file_size_limit() {
    #[cfg(unix)]
    {
        let ignored = std::sync::Arc::new(AtomicBool::new(false));
        if let Err(e) = signal_hook::flag::register(signal_hook::consts::SIGXFSZ, ignored) {
            tracing::warn!("cannot handle SIGXFSZ: {e}; a write past `ulimit -f` will end the process");
        }
    }
}
