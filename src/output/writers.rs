//! The snapshot writers by format: the one place that names the concrete writers ([`super::vtk`],
//! [`super::netcdf`]), above the seam they implement ([`super::snapshot`]).

use super::snapshot::SnapshotWriter;
use crate::error::Result;
use crate::scene::SnapshotFormat;
use std::path::Path;

/// The writer of `format` putting its files under `dir/snapshots` (`dir` is the run
/// directory), or `None` for `format = "none"`.
pub fn writer_for<const D: usize>(
    format: SnapshotFormat,
    dir: &Path,
) -> Result<Option<Box<dyn SnapshotWriter<D>>>> {
    let snaps = dir.join("snapshots");
    match format {
        SnapshotFormat::Vtk => Ok(Some(Box::new(super::vtk::VtkSeries::new(&snaps)?))),
        SnapshotFormat::Netcdf | SnapshotFormat::Netcdf4 => {
            let flavour = if format == SnapshotFormat::Netcdf {
                super::netcdf::Flavour::Classic
            } else {
                super::netcdf::Flavour::Netcdf4
            };
            Ok(Some(Box::new(super::netcdf::NetcdfSeries::new(&snaps, flavour)?)))
        }
        SnapshotFormat::None => Ok(None),
    }
}
