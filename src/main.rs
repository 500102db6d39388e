//! The `sipnpuff` binary: the command line (`sipnpuff::cli`) with the
//! counting allocator installed, so the run report can prove the control
//! thread allocates nothing.

use sipnpuff::rt::alloc_counter::CountingAllocator;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

fn main() -> std::process::ExitCode {
    sipnpuff::cli::main()
}
