//! The `raytracer` command: parse the flags, validate them, run on one pool of worker
//! threads. Every error ends here as one message on stderr and exit code 2.

mod cli;

use clap::Parser;
use cli::options::{self, Options};
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run() -> anyhow::Result<ExitCode> {
    let (options, threads) = options::from_args(cli::args::Args::parse())?;
    // The commands that render run on one pool of worker threads.
    let on_pool = |run: &(dyn Fn(usize) -> anyhow::Result<()> + Sync)| {
        let (pool, threads) = cli::thread_pool(threads)?;
        pool.install(|| run(threads))
    };
    match &options {
        Options::List => cli::list()?,
        Options::Merge(o) => cli::merge::run(o)?,
        Options::Render(o) => on_pool(&|threads| cli::render::run(o, threads))?,
        Options::Reference(o) => on_pool(&|threads| cli::sweep::reference(o, threads))?,
        Options::Sweep(o) => on_pool(&|threads| cli::sweep::sweep(o, threads))?,
    }
    Ok(ExitCode::SUCCESS)
}
