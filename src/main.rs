//! The `hsph` command; see `hsph --help`.
fn main() {
    return_freed_buffers();
    std::process::exit(hsph::cli::main());
}

/// Large allocations (1 MiB and more: particle columns, neighbour lists, a probe's gathered
/// view) are mapped on their own and unmapped when freed. glibc's default raises its mmap
/// threshold to the size of the largest block freed (up to 32 MiB), after which such buffers
/// come from the heap and their pages stay resident once freed: a whole 3D dam-break run on one
/// rank peaked at 147.5 MB of RSS for 138.0 MB of live heap, and at 135.3 MB with the fixed
/// threshold, at the same speed (docs/benchmark-log.md, "A probe's view holds what probes read").
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
fn return_freed_buffers() {
    // SAFETY: mallopt only sets an allocator parameter; called before any thread starts. A
    // failure (return 0) leaves glibc's default, which is correct, only less frugal.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

/// Other allocators return freed buffers by their own rules.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn return_freed_buffers() {}
