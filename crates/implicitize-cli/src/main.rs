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
    refuse_huge_pages();
    cli::run()
}

/// Turns transparent huge pages off for this process (Linux; inherited by its children). With
/// them, mimalloc asks for huge pages over its large regions, and every fresh 2 MiB the kernel
/// hands in is zeroed whole, for allocations that touch a few pages of it: the kernel's zeroing
/// took 10 to 19% of the CPU of a default fit and of `sample`. Without them, the default fit of
/// the triceratops took 1.43 to 1.53 s against 1.48 to 1.87 s, the bunny's 5.67 to 6.26 s
/// against 6.45 to 7.24 s, `sample -n 500000` 0.95 to 1.15 s against 0.97 to 1.45 s, and the
/// triceratops's fit and `sample` a fifth less memory at the peak (docs/results.md, "Huge
/// pages"). A kernel that refuses the call leaves the default.
fn refuse_huge_pages() {
    #[cfg(target_os = "linux")]
    // SAFETY: PR_SET_THP_DISABLE reads only its integer arguments and touches no memory of ours.
    unsafe {
        libc::prctl(
            libc::PR_SET_THP_DISABLE,
            1 as libc::c_ulong,
            0 as libc::c_ulong,
            0 as libc::c_ulong,
            0 as libc::c_ulong,
        );
    }
}
