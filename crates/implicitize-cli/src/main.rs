//! The `implicitize` command-line tool: a thin front end over the library, and the paper's
//! figures 2 and 3, which only its `fit2d` and `render` commands draw.

mod cli;
mod figure2;
mod figure3;

// The fit allocates and frees several volumes of tens of megabytes every iteration. The system
// allocator hands such blocks back to the kernel on each free and faults fresh pages in on the
// next allocation; mimalloc reuses much of that memory, which took about 4% off fits of the
// horse at 337 (10.55 s to 10.17 s, the mean of four runs each).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    cli::run()
}
