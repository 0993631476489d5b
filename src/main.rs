//! The `hdrflow` command line: arguments and reporting only; the work is in the library.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
