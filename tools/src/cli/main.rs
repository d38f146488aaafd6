//! `raybatch`, the command-line tool: `bench` measures the trees on built-in scenes or a user
//! mesh, `query` answers a file of rays against an OBJ mesh (or a cooked tree), `rays` writes a benchmark ray set
//! as a ray file, `render` draws a mesh through the queries, `cook`
//! writes a tree and its mesh to a file that loads without a build. See [`args`] and `--help`.
//!
//! Exit codes: 0 on success, 1 when an input or output file is bad, 2 when the command line is.

mod args;
mod bench;
mod compare;
mod cook;
mod error;
mod heap;
mod inputs;
mod json;
mod measure;
mod modes;
mod output;
mod progress;
mod query;
mod rays;
mod records;
mod render;
mod runner;
mod scene_bench;
mod table;
mod workload;

use std::process::ExitCode;

use args::{Cli, Command};
use clap::Parser;
use error::CliError;

/// The system allocator with a high mark, for the builds' peak heap (`heap`).
#[global_allocator]
static ALLOCATOR: heap::Counting = heap::Counting;

fn main() -> ExitCode {
    // Help, version and malformed command lines end here (exit code 0 or 2).
    let command = Cli::parse().command;
    let name = command.name();
    match run(command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("raybatch: error: {e}");
            if let CliError::Usage(_) = e {
                eprintln!("(see raybatch {name} --help)");
            }
            e.exit_code()
        }
    }
}

fn run(command: Command) -> Result<(), CliError> {
    start_rayon();
    match command {
        Command::Bench(a) => bench::run(&a),
        Command::Query(a) => query::run(&a),
        Command::Rays(a) => rays::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Cook(a) => cook::run(&a),
    }
}

/// Starts rayon's global pool, which the commands' parallel iterators use. Where the system
/// refuses threads (a process limit, a sandbox), the pool is this thread alone, so the commands
/// run sequentially instead of panicking; answers never depend on the thread count. (A failed
/// start leaves rayon's global pool unusable, so a thread is tried first.)
fn start_rayon() {
    let threads_start = std::thread::Builder::new()
        .spawn(|| ())
        .is_ok_and(|thread| thread.join().is_ok());
    let builder = rayon::ThreadPoolBuilder::new();
    let builder = if threads_start {
        builder
    } else {
        builder.num_threads(1).use_current_thread()
    };
    // An error here means the pool exists already: nothing to do.
    let _ = builder.build_global();
}
