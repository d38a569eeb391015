//! VTK XML snapshots ParaView opens: one `.vtu` per output step (particles as vertices) and a
//! `.pvd` collection with the simulated time of each. Fields are read from the particle table
//! by their snapshot names, so a new field with a snapshot name can be written at once.

use super::snapshot::SnapshotWriter;
use crate::error::{Error, Result};
use crate::particles::{Column, Particles};
use crate::sim::View;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A series of `.vtu` snapshots in `dir` with its `series.pvd`.
pub struct VtkSeries {
    dir: PathBuf,
    snapshots: Vec<(f64, String)>,
}

impl VtkSeries {
    /// Snapshots go into `dir` (created).
    pub fn new(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(VtkSeries {
            dir: dir.to_path_buf(),
            snapshots: Vec::new(),
        })
    }
}

impl<const D: usize> SnapshotWriter<D> for VtkSeries {
    fn write(&mut self, view: &View<D>, fields: &[String]) -> Result<()> {
        let name = format!("snapshot_{:05}.vtu", self.snapshots.len());
        write_vtu(&self.dir.join(&name), view, &view.by_id(), fields)?;
        self.snapshots.push((view.t, name));
        write_pvd(&self.dir.join("series.pvd"), &self.snapshots)
    }

    fn state(&self) -> serde_json::Value {
        serde_json::json!(self.snapshots)
    }

    fn restore(&mut self, state: &serde_json::Value) -> Result<()> {
        if !state.is_null() {
            self.snapshots = serde_json::from_value(state.clone())
                .map_err(|e| Error::run(format!("checkpoint: snapshot list: {e}")))?;
        }
        Ok(())
    }
}

/// Write one snapshot of the owned particles in `order`, with the snapshot `fields` (names as
/// in `output.fields`; unknown names are skipped: the scene was validated against the table).
pub fn write_vtu<const D: usize>(
    path: &Path,
    sim: &View<D>,
    order: &[usize],
    fields: &[String],
) -> Result<()> {
    let n = order.len();
    let p = &sim.p;
    let table = Particles::<D>::field_table();
    super::write_atomic(path, |f| {
        writeln!(f, "<?xml version=\"1.0\"?>")?;
        writeln!(
            f,
            "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">"
        )?;
        writeln!(
            f,
            "<UnstructuredGrid><Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
        )?;
        writeln!(
            f,
            "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for &i in order {
            let x = p.x[i];
            let z = if D == 3 { x[2] } else { 0.0 };
            writeln!(f, "{} {} {}", x[0], x[1], z)?;
        }
        writeln!(f, "</DataArray></Points>")?;
        writeln!(
            f,
            "<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
        )?;
        for k in 0..n {
            write!(f, "{k} ")?;
        }
        writeln!(
            f,
            "</DataArray><DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
        )?;
        for k in 0..n {
            write!(f, "{} ", k + 1)?;
        }
        writeln!(
            f,
            "</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
        )?;
        for _ in 0..n {
            write!(f, "1 ")?;
        }
        writeln!(f, "</DataArray></Cells>")?;
        writeln!(f, "<PointData>")?;
        write_array(f, "id", &Column::<D>::U64(&p.id), order)?;
        for name in fields {
            let Some(meta) = table.iter().find(|m| m.snapshot == Some(name.as_str())) else {
                continue;
            };
            let col = p.column(meta.name).expect("a table field has a column");
            write_array(f, name, &col, order)?;
        }
        writeln!(f, "</PointData></Piece></UnstructuredGrid></VTKFile>")
    })
}

/// One `<DataArray>` of point data: vectors with 3 components (z = 0 in 2D), one line per
/// point; scalars space separated.
fn write_array<const D: usize>(
    f: &mut impl Write,
    name: &str,
    col: &Column<D>,
    order: &[usize],
) -> std::io::Result<()> {
    let ty = match col {
        Column::U64(_) => "UInt64",
        Column::U16(_) => "UInt16",
        Column::Kind(_) => "UInt8",
        Column::F64(_) | Column::Vector(_) => "Float64",
    };
    if let Column::Vector(v) = col {
        writeln!(
            f,
            "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for &i in order {
            let z = if D == 3 { v[i][2] } else { 0.0 };
            writeln!(f, "{} {} {}", v[i][0], v[i][1], z)?;
        }
    } else {
        writeln!(f, "<DataArray type=\"{ty}\" Name=\"{name}\" format=\"ascii\">")?;
        let mut s = String::new();
        for &i in order {
            s.clear();
            col.csv(i, &mut s);
            write!(f, "{s} ")?;
        }
    }
    writeln!(f, "</DataArray>")
}

/// Write the `.pvd` collection listing every snapshot with its time.
pub fn write_pvd(path: &Path, snaps: &[(f64, String)]) -> Result<()> {
    super::write_atomic(path, |f| {
        writeln!(f, "<?xml version=\"1.0\"?>")?;
        writeln!(f, "<VTKFile type=\"Collection\" version=\"0.1\"><Collection>")?;
        for (t, name) in snaps {
            writeln!(f, "<DataSet timestep=\"{t}\" part=\"0\" file=\"{name}\"/>")?;
        }
        writeln!(f, "</Collection></VTKFile>")
    })
}
