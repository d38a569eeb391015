//! VTK XML snapshots ParaView opens, written in parallel: each rank writes its owned particles
//! (as vertices, in id order) to `snapshot_0000k/rank_000r.vtu`; rank 0 writes the
//! `snapshot_0000k.pvtu` that lists every piece and the `series.pvd` collection with the
//! simulated time of each snapshot. Fields are read from the particle table by their snapshot
//! names, so a new field with a snapshot name can be written at once.

use super::snapshot::{piece_name, Piece, Series, SnapshotWriter};
use crate::error::Result;
use crate::particles::{Column, Particles};
use std::io::Write;
use std::path::Path;

/// A series of parallel `.pvtu` snapshots with its `series.pvd`.
pub struct VtkSeries {
    series: Series,
}

impl VtkSeries {
    /// Snapshots go into `dir` (created).
    pub fn new(dir: &Path) -> Result<Self> {
        Ok(VtkSeries {
            series: Series::new(dir)?,
        })
    }

    /// `series.pvd`: every snapshot written so far.
    fn write_index(&self) -> Result<()> {
        let list: Vec<(f64, String)> = (0..self.series.entries.len())
            .map(|j| (self.series.entries[j].t, format!("snapshot_{j:05}.pvtu")))
            .collect();
        write_pvd(&self.series.dir.join("series.pvd"), &list)
    }
}

impl<const D: usize> SnapshotWriter<D> for VtkSeries {
    fn write(&mut self, piece: &Piece<D>, fields: &[String]) -> Result<()> {
        let path = self.series.next_piece(piece, "vtu")?;
        write_vtu(&path, piece.p, &piece.order, fields)?;
        let k = self.series.entries.len();
        self.series.push(piece);
        if piece.rank != 0 {
            return Ok(());
        }
        let pieces: Vec<String> = (0..piece.ranks).map(|r| piece_name(k, r, "vtu")).collect();
        let index = format!("snapshot_{k:05}.pvtu");
        write_pvtu::<D>(&self.series.dir.join(&index), &pieces, fields)?;
        self.write_index()
    }

    fn state(&self) -> serde_json::Value {
        self.series.state()
    }

    fn restore(&mut self, state: &serde_json::Value, clean: bool) -> Result<()> {
        if self.series.restore(state)? && clean {
            // the index first, so it never lists a snapshot the clean-up removes
            self.write_index()?;
            self.series.remove_later()?;
        }
        Ok(())
    }
}

/// VTK type name of a column.
fn vtk_type<const D: usize>(col: &Column<D>) -> &'static str {
    match col {
        Column::U64(_) => "UInt64",
        Column::U16(_) => "UInt16",
        Column::Kind(_) => "UInt8",
        Column::F64(_) | Column::Vector(_) | Column::Tensor(_) => "Float64",
    }
}

/// The snapshot `fields` this build writes, with their columns in `p`, after the id.
fn point_data<'a, const D: usize>(
    p: &'a Particles<D>,
    fields: &'a [String],
) -> Vec<(&'a str, Column<'a, D>)> {
    let table = Particles::<D>::field_table();
    let mut v = vec![("id", Column::<D>::U64(&p.id))];
    for name in fields {
        if let Some(meta) = table.iter().find(|m| m.snapshot == Some(name.as_str())) {
            v.push((
                name.as_str(),
                p.column(meta.name).expect("a table field has a column"),
            ));
        }
    }
    v
}

/// The parallel index of one snapshot: the arrays every piece holds and the pieces.
fn write_pvtu<const D: usize>(path: &Path, pieces: &[String], fields: &[String]) -> Result<()> {
    // the types and names only: an empty store has the columns
    let empty = Particles::<D>::default();
    super::write_atomic(path, |f| {
        writeln!(f, "<?xml version=\"1.0\"?>")?;
        writeln!(
            f,
            "<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">"
        )?;
        writeln!(f, "<PUnstructuredGrid GhostLevel=\"0\">")?;
        writeln!(f, "<PPointData>")?;
        for (name, col) in point_data(&empty, fields) {
            let comps = if matches!(col, Column::Vector(_)) {
                3
            } else {
                col.components()
            };
            writeln!(
                f,
                "<PDataArray type=\"{}\" Name=\"{name}\" NumberOfComponents=\"{comps}\"/>",
                vtk_type(&col)
            )?;
        }
        writeln!(f, "</PPointData>")?;
        writeln!(
            f,
            "<PPoints><PDataArray type=\"Float64\" NumberOfComponents=\"3\"/></PPoints>"
        )?;
        writeln!(
            f,
            "<PCells><PDataArray type=\"Int64\" Name=\"connectivity\"/>\
             <PDataArray type=\"Int64\" Name=\"offsets\"/>\
             <PDataArray type=\"UInt8\" Name=\"types\"/></PCells>"
        )?;
        for p in pieces {
            writeln!(f, "<Piece Source=\"{p}\"/>")?;
        }
        writeln!(f, "</PUnstructuredGrid></VTKFile>")
    })
}

/// Write one snapshot of the owned particles in `order`, with the snapshot `fields` (names as
/// in `output.fields`; unknown names are skipped: the scene was validated against the table).
pub fn write_vtu<const D: usize>(
    path: &Path,
    p: &Particles<D>,
    order: &[usize],
    fields: &[String],
) -> Result<()> {
    let n = order.len();
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
        for (name, col) in point_data(p, fields) {
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
    let ty = vtk_type(col);
    if let Column::Vector(v) = col {
        writeln!(
            f,
            "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for &i in order {
            let z = if D == 3 { v[i][2] } else { 0.0 };
            writeln!(f, "{} {} {}", v[i][0], v[i][1], z)?;
        }
    } else if let Column::Tensor(_) = col {
        // symmetric: the upper triangle (xx xy yy in 2D, xx xy xz yy yz zz in 3D)
        let comps = col.components();
        writeln!(
            f,
            "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{comps}\" format=\"ascii\">"
        )?;
        for &i in order {
            let line: Vec<String> = (0..comps).map(|k| col.value(i, k).to_string()).collect();
            writeln!(f, "{}", line.join(" "))?;
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
