//! The `caustica` command: parse, call the driver, print.

/// `println!` that goes quiet once standard output is a closed pipe (`caustica compare … | head -c
/// 1`): `println!` panics there, and the work the command is doing (files it writes) must finish.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if !crate::STDOUT_GONE.load(std::sync::atomic::Ordering::Relaxed)
            && let Err(e) = writeln!(std::io::stdout(), $($arg)*)
        {
            crate::stdout_failed(e);
        }
    }};
}

mod args;
mod bench;
mod checkpoint;
mod compare;
mod denoiser;
mod density_plot;
mod display;
mod frames;
mod logging;
mod merge;
mod outputs;
mod plot_text;
mod profile;
mod progress_log;
mod render;
mod report;
mod signals;

use anyhow::Result;
use args::{Cli, Command};
use clap::Parser;
use profile::SystemProfile;

/// Set once standard output has gone (a closed pipe): nothing more is printed to it.
static STDOUT_GONE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// A write to standard output failed: a closed pipe silences it; anything else is said once on
/// standard error.
fn stdout_failed(error: std::io::Error) {
    let first = !STDOUT_GONE.swap(true, std::sync::atomic::Ordering::Relaxed);
    if first && error.kind() != std::io::ErrorKind::BrokenPipe {
        eprintln!("warning: cannot print to standard output: {error}; printing stops");
    }
}

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            // The cause chain on one line, and no backtrace: these are the user's errors to fix.
            eprintln!("error: {error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    // A render's --time-limit counts from here: loading and preparing come out of it.
    let start = std::time::Instant::now();
    signals::writes_fail_past_the_file_size_limit();
    let cli = Cli::parse();
    let render_args = match &cli.command {
        Some(Command::Render(args)) => (**args).clone(),
        _ => (*cli.render).clone(),
    };
    let profile = render_args.profile.then(SystemProfile::default);
    let _chrome_guard =
        logging::install_subscriber(profile.as_ref(), render_args.trace_chrome.as_deref(), cli.verbose)?;
    match cli.command {
        None | Some(Command::Render(_)) => {
            let finished = render::render(&render_args, profile.as_ref(), start)?;
            // Flush the trace before judging it.
            drop(_chrome_guard);
            if !finished {
                std::process::exit(signals::INTERRUPTED_EXIT);
            }
            if logging::TRACE_FAILED.load(std::sync::atomic::Ordering::Relaxed) {
                anyhow::bail!("the Chrome trace could not be written");
            }
            Ok(())
        }
        Some(Command::Merge { parts, output, exposure }) => merge::merge(&parts, &output, exposure),
        Some(Command::Compare { image, reference, window }) => {
            compare::compare_files(&image, &reference, window.as_deref())
        }
        Some(Command::Bench(args)) => {
            caustica::driver::init_thread_pools(None);
            let report = bench::run(&args)?;
            bench::print(&args, &report);
            Ok(())
        }
        Some(Command::Density(args)) => {
            let summary = density_plot::run(&args)?;
            outln!(
                "{} points, h = {:.4} ({}); wrote {}",
                summary.n,
                summary.h,
                summary.h_rule,
                args.output.display()
            );
            Ok(())
        }
    }
}
