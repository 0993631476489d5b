//! The `hdrflow` command line: the library's CLI over the built-in operators.

fn main() -> std::process::ExitCode {
    hdrflow::cli::main()
}
