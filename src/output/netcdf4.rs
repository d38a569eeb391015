//! netCDF-4 snapshot pieces through the system libnetcdf (`netcdf` feature,
//! `output.format = "netcdf4"`): the layout of [`super::cf`] (CF point, dimension
//! `particle`, scalar `time`), with ids as 64-bit unsigned integers and every particle variable
//! compressed (deflate level 4 with byte shuffle). The file is made under a temporary name and
//! renamed into place, so a reader never sees half a file.

use super::cf::{PieceData, Values};
use crate::error::{Error, Result};
use std::path::Path;

/// Deflate level of particle variables (1–9; 4 is the usual balance of size and time).
const DEFLATE: i32 = 4;

fn nc_err(path: &Path, e: netcdf::Error) -> Error {
    Error::io(path, std::io::Error::other(format!("netCDF-4: {e}")))
}

/// Write one snapshot piece as netCDF-4.
pub(crate) fn write_file(path: &Path, data: &PieceData) -> Result<()> {
    let tmp = path.with_extension("nc.tmp");
    let result = fill(&tmp, data).map_err(|e| nc_err(path, e));
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

fn fill(path: &Path, data: &PieceData) -> netcdf::Result<()> {
    let mut f = netcdf::create(path)?;
    f.add_dimension("particle", data.n)?;
    for (k, v) in &data.global {
        f.add_attribute(k, v.as_str())?;
    }
    {
        let mut t = f.add_variable::<f64>("time", &[])?;
        for (k, v) in super::cf::TIME_ATTRS {
            t.put_attribute(k, v)?;
        }
        t.put_value(data.t, ..)?;
    }
    {
        let mut s = f.add_variable::<u64>("step", &[])?;
        s.put_attribute("long_name", "time steps taken")?;
        s.put_attribute("units", "1")?;
        s.put_value(data.step, ..)?;
    }
    for v in &data.vars {
        let mut var = match &v.values {
            Values::I8(_) => f.add_variable::<i8>(&v.name, &["particle"])?,
            Values::I32(_) => f.add_variable::<i32>(&v.name, &["particle"])?,
            Values::U64(_) => f.add_variable::<u64>(&v.name, &["particle"])?,
            Values::F64(_) => f.add_variable::<f64>(&v.name, &["particle"])?,
        };
        if data.n > 0 {
            var.set_compression(DEFLATE, true)?;
        }
        var.put_attribute("units", v.unit.as_str())?;
        var.put_attribute("long_name", v.long_name.as_str())?;
        if ["x", "y", "z"].contains(&v.name.as_str()) {
            var.put_attribute("axis", v.name.to_uppercase().as_str())?;
        } else {
            var.put_attribute("coordinates", data.coordinates)?;
        }
        match &v.values {
            Values::I8(x) => var.put_values(x, ..)?,
            Values::I32(x) => var.put_values(x, ..)?,
            Values::U64(x) => var.put_values(x, ..)?,
            Values::F64(x) => var.put_values(x, ..)?,
        }
    }
    f.close()
}
