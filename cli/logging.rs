//! Where the command's tracing goes: log lines to stderr, and the per-system profile and the Chrome
//! trace when asked for.

use crate::profile::{SystemProfile, span_label};
use anyhow::{Context, Result};
use std::path::Path;
use tracing_subscriber::EnvFilter;

/// Whether writing the Chrome trace failed (the trace's writer thread cannot return an error).
pub static TRACE_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The Chrome trace's file: a write error (a full disk) is reported once and recorded instead of
/// panicking the writer thread, and the command then exits non-zero.
struct TraceWriter {
    file: std::io::BufWriter<std::fs::File>,
    path: std::path::PathBuf,
}

impl TraceWriter {
    fn record<T>(&self, result: std::io::Result<T>, len: usize) -> std::io::Result<usize> {
        if let Err(e) = result
            && !TRACE_FAILED.swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            eprintln!("error: {}: cannot write the Chrome trace: {e}", self.path.display());
        }
        Ok(len)
    }
}

impl std::io::Write for TraceWriter {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let result = if TRACE_FAILED.load(std::sync::atomic::Ordering::Relaxed) {
            Ok(())
        } else {
            self.file.write_all(bytes)
        };
        self.record(result, bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let result = self.file.flush();
        self.record(result, 0).map(drop)
    }
}

/// The log on stderr (RUST_LOG, default warn; info with -v). Warnings read as sentences: timestamps
/// and the module that logged are for -v.
fn log_layer<S>(verbose: bool) -> Box<dyn tracing_subscriber::Layer<S> + Send + Sync>
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    use tracing_subscriber::prelude::*;
    let default = if verbose { "info" } else { "warn" };
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default));
    let log = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_target(verbose)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
    if verbose { log.with_filter(filter).boxed() } else { log.without_time().with_filter(filter).boxed() }
}

/// Log to stderr (RUST_LOG, default warn), plus the profile and Chrome-trace layers when asked for.
/// The log filter applies to the log layer only, so the others see every system span.
pub fn install_subscriber(
    profile: Option<&SystemProfile>,
    chrome: Option<&Path>,
    verbose: bool,
) -> Result<Option<tracing_chrome::FlushGuard>> {
    use tracing_subscriber::prelude::*;
    if profile.is_none() && chrome.is_none() {
        // Only the log's filter: it disables the per-system spans at their call sites, at no cost.
        tracing_subscriber::registry().with(log_layer(verbose)).init();
        return Ok(None);
    }
    let log = log_layer(verbose);
    let (chrome_layer, guard) = match chrome {
        Some(path) => {
            let file = std::fs::File::create(path)
                .with_context(|| format!("{}: cannot create the Chrome trace", path.display()))?;
            let (layer, guard) = tracing_chrome::ChromeLayerBuilder::new()
                .writer(TraceWriter { file: std::io::BufWriter::new(file), path: path.to_path_buf() })
                .name_fn(Box::new(|event_or_span| match event_or_span {
                    tracing_chrome::EventOrSpan::Span(span) => span_label(span),
                    tracing_chrome::EventOrSpan::Event(event) => event.metadata().name().to_owned(),
                }))
                .build();
            (Some(layer), Some(guard))
        }
        None => (None, None),
    };
    // The profile layer records span names that the Chrome layer's labels read, so it goes first.
    let names = profile.cloned().unwrap_or_default().layer();
    tracing_subscriber::registry().with(names).with(chrome_layer).with(log).init();
    Ok(guard)
}
