//! The `blobtrace` command; everything lives in the library.

fn main() -> std::process::ExitCode {
    blobtrace::cli::main_with_args(std::env::args_os())
}
