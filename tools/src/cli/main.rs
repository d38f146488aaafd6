//! `raybatch`, the command-line tool: `bench` measures the trees on built-in scenes or a user
//! mesh, `query` answers a file of rays against an OBJ mesh, `rays` writes a benchmark ray set
//! as a ray file. See [`args::help`].
//!
//! Exit codes: 0 on success, 1 when an input or output file is bad, 2 when the command line is.

mod args;
mod atomic;
mod bench;
mod compare;
mod error;
mod formats;
mod inputs;
mod json;
mod measure;
mod modes;
mod query;
mod rays;
mod records;
mod runner;
mod scene_bench;
mod table;
mod workload;

use std::ffi::OsString;
use std::process::ExitCode;

use args::Command;
use error::CliError;

fn main() -> ExitCode {
    let args: Vec<OsString> = std::env::args_os().skip(1).collect();
    let usage = usage_for(&args);
    match args::parse(args).and_then(run) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("raybatch: error: {e}");
            if let CliError::Usage(_) = e {
                eprintln!("{usage}");
            }
            e.exit_code()
        }
    }
}

fn run(command: Command) -> Result<(), CliError> {
    match command {
        Command::Help => {
            print!("{}", args::help());
            Ok(())
        }
        Command::Bench(a) => bench::run(&a),
        Command::Query(a) => query::run(&a),
        Command::Rays(a) => rays::run(&a),
    }
}

/// The usage line to show with a usage error, for the subcommand being run.
fn usage_for(args: &[OsString]) -> String {
    match args.first().and_then(|a| a.to_str()) {
        Some("bench") => args::BENCH_USAGE.to_string(),
        Some("query") => args::query_usage(),
        Some("rays") => args::RAYS_USAGE.to_string(),
        _ => args::TOP_USAGE.to_string(),
    }
}
