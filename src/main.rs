//! The `raycaster` command: parses the command line and hands it to the library.

use raycaster::backend::Backend;
use raycaster::cli::{self, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = match cli::parse_args(std::env::args_os().skip(1)) {
        Ok(Command::Help) => {
            println!("{}", cli::USAGE);
            return ExitCode::SUCCESS;
        }
        Ok(Command::Render(args)) => args,
        Err(e) => {
            eprintln!("raycaster: {e}");
            return ExitCode::from(2);
        }
    };
    let backend = match Backend::open(args.backend) {
        Ok((backend, notice)) => {
            if let Some(notice) = notice {
                eprintln!("raycaster: {notice}");
            }
            backend
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            return ExitCode::FAILURE;
        }
    };
    match raycaster::job::run(&args, &backend) {
        Ok(warnings) => {
            for w in warnings {
                eprintln!("raycaster: warning: {w}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::FAILURE
        }
    }
}
