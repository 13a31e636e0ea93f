//! The `implicitize` command-line tool: a thin front end over the library, and the paper's
//! figures 2 and 3, which only its `fit2d` and `render` commands draw.

mod cli;
mod figure2;
mod figure3;

// The fit allocates and frees several volumes of tens of megabytes every iteration. The system
// allocator hands such blocks back to the kernel on each free and faults fresh pages in on the
// next allocation; mimalloc reuses much of that memory instead.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    implicitize::memory::refuse_huge_pages();
    cli::run()
}
