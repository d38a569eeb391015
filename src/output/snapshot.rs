//! The snapshot-writer seam: every snapshot format implements [`SnapshotWriter`] and the run
//! writer holds whichever the scene asks for. VTK is the one today; netCDF and checkpoint
//! writers (cluster-workflow issue) implement the same trait, reading fields through the
//! particle table's columns ([`crate::particles::Particles::column`]) with their units and
//! long names ([`crate::particles::FieldMeta`]).

use crate::error::{Error, Result};
use crate::scene::SnapshotFormat;
use crate::sim::View;
use std::path::Path;

/// Writes one snapshot per output step.
pub trait SnapshotWriter<const D: usize> {
    /// Write the gathered state `view` with the snapshot `fields` (`output.fields`).
    fn write(&mut self, view: &View<D>, fields: &[String]) -> Result<()>;

    /// What a restart needs to continue the series (the snapshots written so far).
    fn state(&self) -> serde_json::Value {
        serde_json::Value::Null
    }

    /// Continue from `state` (from [`SnapshotWriter::state`] of the same format).
    fn restore(&mut self, _state: &serde_json::Value) -> Result<()> {
        Ok(())
    }
}

/// The writer of `format` putting its files under `dir` (the run directory), or `None` for
/// `format = "none"`.
pub fn writer_for<const D: usize>(
    format: SnapshotFormat,
    dir: &Path,
) -> Result<Option<Box<dyn SnapshotWriter<D>>>> {
    match format {
        SnapshotFormat::Vtk => Ok(Some(Box::new(super::vtk::VtkSeries::new(
            &dir.join("snapshots"),
        )?))),
        SnapshotFormat::None => Ok(None),
        SnapshotFormat::Netcdf => Err(Error::missing_feature("output.format", "netcdf")),
    }
}
