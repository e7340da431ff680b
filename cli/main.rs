//! The `caustica` command: parse, call the driver, print.

mod args;
mod bench;
mod compare;
mod density_plot;
mod logging;
mod profile;
mod render;
mod report;

use anyhow::Result;
use args::{Cli, Command, RenderArgs};
use clap::Parser;
use profile::SystemProfile;

fn main() -> Result<()> {
    let cli = Cli::parse();
    let render_args = match &cli.command {
        Some(Command::Render(args)) => (**args).clone(),
        _ => RenderArgs::default(),
    };
    let profile = render_args.profile.then(SystemProfile::default);
    let _chrome_guard = logging::install_subscriber(profile.as_ref(), render_args.trace_chrome.as_deref())?;
    match cli.command {
        None | Some(Command::Render(_)) => {
            let finished = render::render(&render_args)?;
            if let Some(profile) = profile {
                println!("\nper-system profile (tracing spans)\n{}", profile.table());
            }
            if !finished {
                drop(_chrome_guard);
                std::process::exit(render::INTERRUPTED_EXIT);
            }
            Ok(())
        }
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
