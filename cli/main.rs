//! The `caustica` command: parse, call the driver, print.

mod args;
mod bench;
mod checkpoint;
mod compare;
mod density_plot;
mod display;
mod logging;
mod profile;
mod render;
mod report;

use anyhow::Result;
use args::{Cli, Command};
use clap::Parser;
use profile::SystemProfile;

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
            let finished = render::render(&render_args, profile.as_ref())?;
            // Flush the trace before judging it.
            drop(_chrome_guard);
            if !finished {
                std::process::exit(render::INTERRUPTED_EXIT);
            }
            if logging::TRACE_FAILED.load(std::sync::atomic::Ordering::Relaxed) {
                anyhow::bail!("the Chrome trace could not be written");
            }
            Ok(())
        }
        Some(Command::Merge { parts, output, exposure }) => render::merge(&parts, &output, exposure),
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
            println!(
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
