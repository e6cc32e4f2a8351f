//! shellwarp command-line interface: parses arguments, then calls one function per subcommand.

mod cli;

use std::io::ErrorKind::BrokenPipe;
use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    if let Some(code) = cli::rerun_quietly(&args) {
        return code;
    }
    match cli::run(args) {
        Ok(code) => code,
        // Whoever read the output stopped reading (`| head`): nothing is wrong with the run.
        Err(e) if e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == BrokenPipe)) => {
            ExitCode::SUCCESS
        }
        Err(e) => {
            // One clear line: the chain of contexts, outermost first.
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
