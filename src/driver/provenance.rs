//! What built this binary (version, git commit, cargo features, MPI library), for the
//! banner and `summary.json`.

use super::Backend;
use serde_json::json;

/// Cargo features this binary was built with.
pub fn features() -> Vec<&'static str> {
    let mut f = Vec::new();
    if cfg!(feature = "mpi") {
        f.push("mpi");
    }
    if cfg!(feature = "hwloc") {
        f.push("hwloc");
    }
    if cfg!(feature = "netcdf") {
        f.push("netcdf");
    }
    f
}

/// What built this binary: version, git commit, cargo features and, on the MPI back end, the
/// MPI library (first line of `MPI_Get_library_version`).
pub fn provenance(backend: Backend) -> serde_json::Value {
    #[cfg(feature = "mpi")]
    let mpi = (backend == Backend::Mpi).then(|| {
        let v = crate::comm::mpi::MpiComm::library_version();
        v.lines().next().unwrap_or("").trim().to_string()
    });
    #[cfg(not(feature = "mpi"))]
    let mpi: Option<String> = {
        let _ = backend;
        None
    };
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "git_commit": env!("HSPH_GIT_COMMIT"),
        "features": features(),
        "mpi_library": mpi,
    })
}
