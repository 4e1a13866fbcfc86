//! The `blobtrace` command; everything lives in the library.

/// mimalloc keeps the memory a job frees for its next allocations. With the
/// system allocator, the polygonizer's bricks and lists went back to the
/// system and came back as fresh pages, whose faults (slow here when two
/// threads take them at once) cost a quarter of a polygonization.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    blobtrace::cli::main_with_args(std::env::args_os())
}
