//! The `lash` command-line binary: a thin shell around [`lash_cli`].

/// jemalloc instead of the system allocator (where it builds: not with MSVC): building and
/// dropping the runs of a sweep allocates (variable tables, scenario trees, per-run buffers), and
/// glibc's allocator spent ~40 % of a sweep of short runs in malloc, free and the consolidation of
/// its free lists (docs/performance.md, session 17). Results do not depend on the allocator.
#[cfg(not(target_env = "msvc"))]
#[global_allocator]
static ALLOCATOR: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() -> std::process::ExitCode {
    lash_cli::main()
}
