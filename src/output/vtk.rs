//! VTK XML snapshots ParaView opens: one `.vtu` per output step (particles as vertices) and a
//! `.pvd` collection with the simulated time of each.

use crate::error::{Error, Result};
use crate::sim::View;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Write one snapshot of the owned particles in id order.
pub fn write_vtu<const D: usize>(
    path: &Path,
    sim: &View<D>,
    order: &[usize],
    fields: &[String],
) -> Result<()> {
    let io = |e| Error::io(path, e);
    let mut f = BufWriter::new(File::create(path).map_err(io)?);
    let n = order.len();
    let p = &sim.p;
    writeln!(f, "<?xml version=\"1.0\"?>").map_err(io)?;
    writeln!(
        f,
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">"
    )
    .map_err(io)?;
    writeln!(
        f,
        "<UnstructuredGrid><Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
    )
    .map_err(io)?;
    writeln!(
        f,
        "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">"
    )
    .map_err(io)?;
    for &i in order {
        let x = p.x[i];
        let z = if D == 3 { x[2] } else { 0.0 };
        writeln!(f, "{} {} {}", x[0], x[1], z).map_err(io)?;
    }
    writeln!(f, "</DataArray></Points>").map_err(io)?;
    writeln!(
        f,
        "<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
    )
    .map_err(io)?;
    for k in 0..n {
        write!(f, "{k} ").map_err(io)?;
    }
    writeln!(
        f,
        "</DataArray><DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
    )
    .map_err(io)?;
    for k in 0..n {
        write!(f, "{} ", k + 1).map_err(io)?;
    }
    writeln!(
        f,
        "</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
    )
    .map_err(io)?;
    for _ in 0..n {
        write!(f, "1 ").map_err(io)?;
    }
    writeln!(f, "</DataArray></Cells>").map_err(io)?;
    writeln!(f, "<PointData>").map_err(io)?;
    writeln!(f, "<DataArray type=\"UInt64\" Name=\"id\" format=\"ascii\">").map_err(io)?;
    for &i in order {
        write!(f, "{} ", p.id[i]).map_err(io)?;
    }
    writeln!(f, "</DataArray>").map_err(io)?;
    for field in fields {
        match field.as_str() {
            "velocity" => {
                writeln!(f, "<DataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"ascii\">").map_err(io)?;
                for &i in order {
                    let v = p.v[i];
                    let z = if D == 3 { v[2] } else { 0.0 };
                    writeln!(f, "{} {} {}", v[0], v[1], z).map_err(io)?;
                }
                writeln!(f, "</DataArray>").map_err(io)?;
            }
            "density" | "pressure" | "mass" => {
                let (name, data) = match field.as_str() {
                    "density" => ("density", &p.rho),
                    "pressure" => ("pressure", &p.p),
                    _ => ("mass", &p.mass),
                };
                writeln!(f, "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">").map_err(io)?;
                for &i in order {
                    write!(f, "{} ", data[i]).map_err(io)?;
                }
                writeln!(f, "</DataArray>").map_err(io)?;
            }
            "kind" => {
                writeln!(f, "<DataArray type=\"UInt8\" Name=\"kind\" format=\"ascii\">").map_err(io)?;
                for &i in order {
                    write!(f, "{} ", p.kind[i].code()).map_err(io)?;
                }
                writeln!(f, "</DataArray>").map_err(io)?;
            }
            _ => {}
        }
    }
    writeln!(f, "</PointData></Piece></UnstructuredGrid></VTKFile>").map_err(io)?;
    f.flush().map_err(io)
}

/// Write the `.pvd` collection listing every snapshot with its time.
pub fn write_pvd(path: &Path, snaps: &[(f64, String)]) -> Result<()> {
    let io = |e| Error::io(path, e);
    let mut f = BufWriter::new(File::create(path).map_err(io)?);
    writeln!(f, "<?xml version=\"1.0\"?>").map_err(io)?;
    writeln!(f, "<VTKFile type=\"Collection\" version=\"0.1\"><Collection>").map_err(io)?;
    for (t, name) in snaps {
        writeln!(f, "<DataSet timestep=\"{t}\" part=\"0\" file=\"{name}\"/>").map_err(io)?;
    }
    writeln!(f, "</Collection></VTKFile>").map_err(io)?;
    f.flush().map_err(io)
}
