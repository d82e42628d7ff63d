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
    if let Options::List = options {
        cli::list()?;
        return Ok(ExitCode::SUCCESS);
    }
    let (pool, threads) = cli::thread_pool(threads)?;
    pool.install(|| match &options {
        Options::List => Ok(()),
        Options::Render(o) => cli::render::run(o, threads),
        Options::Reference(o) => cli::sweep::reference(o, threads),
        Options::Sweep(o) => cli::sweep::sweep(o, threads),
    })?;
    Ok(ExitCode::SUCCESS)
}
