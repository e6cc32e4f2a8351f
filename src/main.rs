//! shellwarp command-line interface: parses arguments, then calls one function per subcommand.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    if let Some(code) = cli::rerun_quietly(&args) {
        return code;
    }
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            // One clear line: the chain of contexts, outermost first.
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
