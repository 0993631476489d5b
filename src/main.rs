//! The `hdrflow` command line: the library's CLI over the built-in operators, plus `bench`, the
//! benchmark (a module of this binary, not of the library: `bench/`).

mod bench;

fn main() -> std::process::ExitCode {
    hdrflow::cli::main_with_extra::<bench::command::BinaryCommands>(hdrflow::builtin_registry())
}
