//! The `raytracer` command: parse the flags, validate them, run on one pool of worker
//! threads. Every error ends here as one message on stderr and exit code 2; a reader of
//! standard output that goes away early (`raytracer --list | head -1`) ends the run with
//! exit code 0.

#[macro_use]
mod cli;

use clap::Parser;
use cli::options::{self, Options};
use raytracer::output;
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) if e.is::<cli::StdoutClosed>() => ExitCode::SUCCESS,
        Err(e) => {
            to_stderr!("error: {}", raytracer::one_line(&format!("{e:#}")));
            ExitCode::from(2)
        }
    }
}

fn run() -> anyhow::Result<ExitCode> {
    let args = cli::args::Args::parse();
    // `--list` writes no file and needs no thread.
    if args.command.is_none() && args.list {
        cli::list()?;
        return Ok(ExitCode::SUCCESS);
    }
    // Before any file exists (checking the outputs creates probe files): a SIGINT or
    // SIGTERM from here on removes this run's temporary files.
    #[cfg(unix)]
    output::install_signal_cleanup().map_err(|e| {
        anyhow::anyhow!("cannot start the thread that cleans up after a signal: {e}")
    })?;
    let (options, threads) = options::from_args(args)?;
    // Temporary files that a killed run left in the output directories.
    for dir in options.output_dirs() {
        let removed = output::remove_stale_temporaries(&dir);
        if !removed.is_empty() {
            to_stderr!(
                "note: removed {} temporary files that a killed run left in {}",
                removed.len(),
                dir.display()
            );
        }
    }
    let (pool, threads) = cli::thread_pool(threads)?;
    pool.install(|| match &options {
        Options::List => Ok(()),
        Options::Merge(o) => cli::merge::run(o),
        Options::Render(o) => cli::render::run(o, threads),
        Options::Reference(o) => cli::sweep::reference(o, threads),
        Options::Sweep(o) => cli::sweep::sweep(o, threads),
        Options::View(o) => cli::view::run(o),
    })?;
    Ok(ExitCode::SUCCESS)
}
