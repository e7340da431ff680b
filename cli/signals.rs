//! Ctrl-C and SIGTERM during a render (one image or an animation's frames): the render stops at its
//! next step and writes what it has; a second signal exits at once.

use caustica::Renderer;

/// Exit status of a render that a signal stopped: the image so far was written, but the render is not
/// what was asked for (128 + SIGINT, as shells report it).
pub const INTERRUPTED_EXIT: i32 = 130;

/// SIGINT and SIGTERM raise the renderer's interrupt flag: the render stops at its next step and the
/// image so far is written. A second signal exits at once.
pub(crate) fn watch_for_signals(renderer: &Renderer) {
    let flag = renderer.interrupt_flag();
    let result = ctrlc::set_handler(move || {
        if flag.swap(true, std::sync::atomic::Ordering::Relaxed) {
            eprintln!("\nstopped at once: nothing more is written");
            // A write cut short leaves no partial file beside its output (the previous file stays).
            caustica::film::partial::remove_all();
            std::process::exit(INTERRUPTED_EXIT);
        }
        eprintln!(
            "\nstopping: finishing the paths in flight and writing the image so far (again to quit now)"
        );
    });
    if let Err(e) = result {
        tracing::warn!("cannot watch for Ctrl-C: {e}; an interrupted render will not write its image");
    }
}
