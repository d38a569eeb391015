//! netCDF output in the default build: netCDF-3 with 64-bit offsets (CDF-2), written by the
//! pure-Rust `netcdf3` crate, read by `ncdump`, the netCDF-C library, netCDF4-python and xarray.
//!
//! **Snapshots** (`output.format = "netcdf"`): one file per snapshot and rank,
//! `snapshots/snapshot_0000k/rank_000r.nc`, holding that rank's owned particles in id order, and
//! `snapshots/series.json`, the manifest that lists every snapshot's time, step and pieces.
//! Each file follows the CF conventions' discrete-sampling-geometry *point* layout
//! (`featureType = "point"`): one dimension `particle`; a scalar `time` (s); coordinates `x`,
//! `y` (and `z`) in m; then `id` and the fields of `output.fields` with `units` and `long_name`
//! from the particle table (vectors one variable per component: `velocity_x`, …). The point
//! layout fits because particles are scattered samples without a grid; a snapshot's pieces are
//! concatenated along `particle` (xarray: `open_mfdataset(pieces, combine="nested",
//! concat_dim="particle")`).
//!
//! **Series** (`timeseries.nc`, `probes/<name>.nc`): the CSV series mirrored with an unlimited
//! `time` dimension (a coordinate variable `time` in s), rewritten from the CSV at every output
//! step, so a restart that cuts the CSV back cuts the netCDF file back too. In 2D, extensive
//! quantities are per metre of depth (units say so).

use super::cf::{piece_data, source, PieceData, Values, CONVENTIONS, TIME_ATTRS};
use super::snapshot::{piece_name, Piece, Series, SnapshotWriter};
use crate::error::{Error, Result};
use netcdf3::{DataSet, FileWriter, Version};
use std::cell::RefCell;
use std::io::{Cursor, Seek, SeekFrom, Write};
use std::path::Path;
use std::rc::Rc;

/// Which netCDF a series writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flavour {
    /// netCDF-3 with 64-bit offsets (CDF-2), pure Rust.
    Classic,
    /// netCDF-4 (HDF5) with deflate and shuffle, through the system library (`netcdf` feature).
    Netcdf4,
}

/// A series of per-rank netCDF snapshots with its `series.json`.
pub struct NetcdfSeries {
    series: Series,
    flavour: Flavour,
}

impl NetcdfSeries {
    /// Snapshots of `flavour` go into `dir` (created).
    pub fn new(dir: &Path, flavour: Flavour) -> Result<Self> {
        Ok(NetcdfSeries {
            series: Series::new(dir)?,
            flavour,
        })
    }

    /// `series.json`: format, conventions and every snapshot with its pieces.
    fn write_manifest(&self) -> Result<()> {
        let snaps: Vec<serde_json::Value> = self
            .series
            .entries
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let pieces: Vec<String> = (0..e.pieces).map(|r| piece_name(k, r, "nc")).collect();
                serde_json::json!({ "t": e.t, "step": e.step, "pieces": pieces })
            })
            .collect();
        let m = serde_json::json!({
            "format": match self.flavour {
                Flavour::Classic => "netCDF-3 64-bit offset (CDF-2)",
                Flavour::Netcdf4 => "netCDF-4 (deflate level 4, shuffle)",
            },
            "conventions": CONVENTIONS,
            "featureType": "point",
            "concat_dim": "particle",
            "snapshots": snaps,
        });
        let text = serde_json::to_string_pretty(&m).map_err(|e| Error::run(e.to_string()))?;
        let path = self.series.dir.join("series.json");
        super::write_atomic(&path, |f| writeln!(f, "{text}"))
    }
}

impl<const D: usize> SnapshotWriter<D> for NetcdfSeries {
    fn write(&mut self, piece: &Piece<D>, fields: &[String]) -> Result<()> {
        let path = self.series.next_piece(piece, "nc")?;
        let data = piece_data(piece, fields);
        match self.flavour {
            Flavour::Classic => write_file(&path, &data)?,
            #[cfg(feature = "netcdf")]
            Flavour::Netcdf4 => super::netcdf4::write_file(&path, &data)?,
            #[cfg(not(feature = "netcdf"))]
            Flavour::Netcdf4 => return Err(Error::missing_feature("output.format", "netcdf")),
        }
        self.series.push(piece);
        if piece.rank == 0 {
            self.write_manifest()?;
        }
        Ok(())
    }

    fn state(&self) -> serde_json::Value {
        self.series.state()
    }

    fn restore(&mut self, state: &serde_json::Value, clean: bool) -> Result<()> {
        if self.series.restore(state)? && clean {
            // the index first, so it never lists a snapshot the clean-up removes
            self.write_manifest()?;
            self.series.remove_later()?;
        }
        Ok(())
    }
}

/// The classic-format form of `values` (ids as int or double).
fn classic(values: &Values) -> std::borrow::Cow<'_, Values> {
    match values {
        Values::U64(u) if u.iter().all(|&v| v <= i32::MAX as u64) => {
            std::borrow::Cow::Owned(Values::I32(u.iter().map(|&v| v as i32).collect()))
        }
        Values::U64(u) => std::borrow::Cow::Owned(Values::F64(u.iter().map(|&v| v as f64).collect())),
        _ => std::borrow::Cow::Borrowed(values),
    }
}

fn nc_err(path: &Path, e: impl std::fmt::Debug) -> Error {
    Error::io(path, std::io::Error::other(format!("netCDF: {e:?}")))
}

/// Write a classic (CDF-2) snapshot file: dimension `particle`, a scalar `time` and `step`,
/// the variables along `particle` (atomically: temporary file, then rename).
/// One piece written alone as a classic netCDF file (CDF-2, pure Rust) in the snapshots' CF
/// point layout: `hsph check --preview`'s `particles.nc`.
pub fn write_piece<const D: usize>(path: &Path, piece: &Piece<D>, fields: &[String]) -> Result<()> {
    write_file(path, &piece_data(piece, fields))
}

fn write_file(path: &Path, data: &PieceData) -> Result<()> {
    let e = |err| nc_err(path, err);
    let (vars, coordinates) = (&data.vars, data.coordinates);
    let values: Vec<_> = vars.iter().map(|v| classic(&v.values)).collect();
    let mut ds = DataSet::new();
    ds.add_fixed_dim("particle", data.n).map_err(e)?;
    for (k, v) in &data.global {
        ds.add_global_attr_string(k, v).map_err(e)?;
    }
    ds.add_var_f64::<&str>("time", &[]).map_err(e)?;
    for (k, v) in TIME_ATTRS {
        ds.add_var_attr_string("time", k, v).map_err(e)?;
    }
    ds.add_var_i32::<&str>("step", &[]).map_err(e)?;
    ds.add_var_attr_string("step", "long_name", "time steps taken")
        .map_err(e)?;
    ds.add_var_attr_string("step", "units", "1").map_err(e)?;
    for (v, values) in vars.iter().zip(&values) {
        match values.as_ref() {
            Values::I8(_) => ds.add_var_i8(&v.name, &["particle"]),
            Values::I32(_) => ds.add_var_i32(&v.name, &["particle"]),
            Values::U64(_) | Values::F64(_) => ds.add_var_f64(&v.name, &["particle"]),
        }
        .map_err(e)?;
        ds.add_var_attr_string(&v.name, "units", &v.unit).map_err(e)?;
        ds.add_var_attr_string(&v.name, "long_name", &v.long_name)
            .map_err(e)?;
        if ["x", "y", "z"].contains(&v.name.as_str()) {
            ds.add_var_attr_string(&v.name, "axis", v.name.to_uppercase())
                .map_err(e)?;
        } else {
            ds.add_var_attr_string(&v.name, "coordinates", coordinates)
                .map_err(e)?;
        }
    }
    write_dataset(path, &ds, |w| {
        w.write_var_f64("time", &[data.t])?;
        w.write_var_i32("step", &[i32::try_from(data.step).unwrap_or(i32::MAX)])?;
        for (v, values) in vars.iter().zip(&values) {
            match values.as_ref() {
                Values::I8(x) => w.write_var_i8(&v.name, x)?,
                Values::I32(x) => w.write_var_i32(&v.name, x)?,
                Values::F64(x) => w.write_var_f64(&v.name, x)?,
                Values::U64(_) => unreachable!("classic() converted the ids"),
            }
        }
        Ok(())
    })
}

/// The bytes of a file being made: the netCDF writer seeks and writes into memory, and the
/// whole file then goes to disk through [`super::write_atomic`] (temporary file, rename; the
/// test-only full-disk switch applies as to every output file).
#[derive(Clone, Default)]
struct Memory(Rc<RefCell<Cursor<Vec<u8>>>>);

impl Write for Memory {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for Memory {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.borrow_mut().seek(pos)
    }
}

/// Write `ds` to `path`, its data through `fill`.
fn write_dataset(
    path: &Path,
    ds: &DataSet,
    fill: impl FnOnce(&mut FileWriter) -> std::result::Result<(), netcdf3::WriteError>,
) -> Result<()> {
    let mem = Memory::default();
    let mut w = FileWriter::open_seek_write(&path.to_string_lossy(), Box::new(mem.clone()))
        .map_err(|e| nc_err(path, e))?;
    w.set_def(ds, Version::Offset64Bit, 0)
        .map_err(|e| nc_err(path, e))?;
    fill(&mut w).map_err(|e| nc_err(path, e))?;
    w.close().map_err(|e| nc_err(path, e))?;
    let bytes = std::mem::take(mem.0.borrow_mut().get_mut());
    super::write_atomic(path, |f| f.write_all(&bytes))
}

/// Units and long name of a series column (`timeseries.csv` or a probe file) in `D`
/// dimensions; unknown columns get none.
fn series_meta(col: &str, d: usize) -> (String, String) {
    let depth = if d == 2 { " m-1" } else { "" };
    let (unit, long): (String, &str) = match col {
        "dt" => ("s".into(), "time step"),
        "kinetic_energy" => (format!("J{depth}"), "kinetic energy"),
        "potential_energy" => (format!("J{depth}"), "potential energy in gravity"),
        "internal_energy" => (format!("J{depth}"), "internal (compression) energy"),
        "total_energy" => (format!("J{depth}"), "total energy"),
        "mass" => (format!("kg{depth}"), "total mass"),
        "removed_energy" => (format!("J{depth}"), "energy carried out by removed particles"),
        "removed_mass" => (format!("kg{depth}"), "mass carried out by removed particles"),
        "max_speed" => ("m s-1".into(), "largest particle speed"),
        "p" => ("Pa".into(), "pressure at the sensor"),
        "eta" => ("m".into(), "water level at the gauge"),
        "front" => ("m".into(), "position of the front"),
        "fx" | "fy" | "fz" => (format!("N{depth}"), "force of the fluid on the wall"),
        "mx" | "my" | "mz" => (
            if d == 2 { "N".into() } else { "N m".into() },
            "moment of the fluid on the wall",
        ),
        c if c.starts_with("momentum_") => (
            if d == 2 {
                "kg s-1".into()
            } else {
                "kg m s-1".into()
            },
            "total momentum",
        ),
        c if c.starts_with('s') && c.contains("_v") => ("m s-1".into(), "velocity at the line point"),
        _ => (String::new(), ""),
    };
    (unit, long.to_string())
}

/// Mirror a CSV series (header `step,t,…` or `t,…`, numbers only) into a netCDF file with an
/// unlimited `time` dimension; `t` becomes the coordinate variable `time` (s), `step` an int.
pub fn mirror_series(csv: &Path, nc: &Path, title: &str, d: usize) -> Result<()> {
    let text = std::fs::read_to_string(csv).map_err(|e| Error::io(csv, e))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for (k, line) in lines.enumerate() {
        let vals: Vec<&str> = line.split(',').collect();
        if vals.len() != header.len() {
            // a row cut off by a crash: the mirror ends before it
            break;
        }
        let parsed: Option<Vec<f64>> = vals.iter().map(|v| v.parse::<f64>().ok()).collect();
        let Some(parsed) = parsed else {
            return Err(Error::run(format!(
                "{}: row {} is not numeric",
                csv.display(),
                k + 2
            )));
        };
        for (c, v) in cols.iter_mut().zip(parsed) {
            c.push(v);
        }
    }
    let rows = cols.first().map_or(0, Vec::len);
    let e = |err| nc_err(nc, err);
    let mut ds = DataSet::new();
    ds.set_unlimited_dim("time", rows).map_err(e)?;
    for (k, v) in [
        ("title", title.to_string()),
        ("Conventions", CONVENTIONS.to_string()),
        ("source", source()),
        (
            "history",
            format!(
                "mirrors {}",
                csv.file_name().unwrap_or_default().to_string_lossy()
            ),
        ),
    ] {
        ds.add_global_attr_string(k, v).map_err(e)?;
    }
    let names: Vec<String> = header
        .iter()
        .map(|h| {
            if *h == "t" {
                "time".to_string()
            } else {
                h.to_string()
            }
        })
        .collect();
    for name in &names {
        if name == "step" {
            ds.add_var_i32(name, &["time"]).map_err(e)?;
            ds.add_var_attr_string(name, "long_name", "time steps taken")
                .map_err(e)?;
            ds.add_var_attr_string(name, "units", "1").map_err(e)?;
        } else if name == "time" {
            ds.add_var_f64(name, &["time"]).map_err(e)?;
            for (k, v) in TIME_ATTRS {
                ds.add_var_attr_string(name, k, v).map_err(e)?;
            }
        } else {
            ds.add_var_f64(name, &["time"]).map_err(e)?;
            let (unit, long) = series_meta(name, d);
            if !unit.is_empty() {
                ds.add_var_attr_string(name, "units", unit).map_err(e)?;
                ds.add_var_attr_string(name, "long_name", long).map_err(e)?;
            }
        }
    }
    write_dataset(nc, &ds, |w| {
        for (name, col) in names.iter().zip(&cols) {
            if name == "step" {
                let s: Vec<i32> = col.iter().map(|&v| v as i32).collect();
                w.write_var_i32(name, &s)?;
            } else {
                w.write_var_f64(name, col)?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_series_mirror_reads_back_with_its_units_and_every_row() {
        let dir = std::env::temp_dir().join(format!("hsph-nc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let csv = dir.join("ts.csv");
        std::fs::write(
            &csv,
            "step,t,kinetic_energy,mass\n0,0,0,1.5\n3,0.1,2.25,1.5\n7,0.2,0.1,1.5\n9,0.3",
        )
        .unwrap();
        let nc = dir.join("ts.nc");
        mirror_series(&csv, &nc, "test", 2).unwrap();
        let mut r = netcdf3::FileReader::open(&nc).unwrap();
        assert_eq!(r.version(), Version::Offset64Bit);
        let ds = r.data_set();
        assert_eq!(ds.num_records(), Some(3), "the cut-off last row is left out");
        assert_eq!(
            ds.get_var_attr("kinetic_energy", "units")
                .unwrap()
                .get_as_string(),
            Some("J m-1".to_string())
        );
        assert_eq!(r.read_var_i32("step").unwrap(), vec![0, 3, 7]);
        assert_eq!(r.read_var_f64("time").unwrap(), vec![0.0, 0.1, 0.2]);
        assert_eq!(r.read_var_f64("kinetic_energy").unwrap(), vec![0.0, 2.25, 0.1]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
