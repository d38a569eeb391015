//! A run's written state as the report's pictures read it: `final.csv`, the per-rank pieces
//! of a final state above `output.gather_limit`, or a flow frame's pieces — the particles'
//! kind, body and position, and one column to colour them by.

use crate::error::{Error, Result};
use crate::limits::{FileNumbers, Number};
use crate::particles::{Kind, Particles, Record};
use crate::Vector;
use std::path::{Path, PathBuf};

/// Particles (kind, body, position, `failed` where written) and the colouring column.
pub(super) struct State<const D: usize> {
    pub p: Particles<D>,
    pub values: Vec<f64>,
}

/// Read the files `paths` (each with `final.csv`'s columns) into one state: kind, body,
/// position and the column `field`, through the bounded reader. Every row has its header's
/// fields and every number is checked where it is read (a kind hsph writes, a body index,
/// finite positions): exit 2 naming the file, line and column.
pub(super) fn read_state<const D: usize>(paths: &[PathBuf], field: &str) -> Result<State<D>> {
    let mut out = State {
        p: Particles::<D>::default(),
        values: Vec::new(),
    };
    for path in paths {
        read_into(path, field, &mut out)?;
    }
    Ok(out)
}

fn read_into<const D: usize>(path: &Path, field: &str, out: &mut State<D>) -> Result<()> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    let not_final = || {
        Error::run(format!(
            "{}: not a final.csv with id, kind, body, x",
            path.display()
        ))
    };
    let mut head: Vec<String> = Vec::new();
    let mut cols: Option<[usize; 5]> = None;
    let mut failed = None;
    crate::limits::read_lines(path, "final.csv", |n, line| {
        if head.is_empty() {
            head = line.split(',').map(str::to_string).collect();
            let col = |name: &str| head.iter().position(|h| h == name);
            failed = col("failed");
            let (Some(id), Some(kind), Some(body), Some(x)) = (col("id"), col("kind"), col("body"), col("x"))
            else {
                return Err(not_final());
            };
            let Some(f) = col(field) else {
                return Err(Error::input(
                    "--field",
                    format!(
                        "`{field}` is not a column of {}; columns: {}",
                        path.display(),
                        head.join(", ")
                    ),
                ));
            };
            if x + D > head.len() || (0..D).any(|a| head[x + a] != AXES[a]) {
                let want = AXES[..D].join(", ");
                return Err(FileNumbers::at(path, n).error("x", format!("needs the columns {want}")));
            }
            cols = Some([id, kind, body, x, f]);
            return Ok(());
        }
        let Some([id, kind, body, x, f]) = cols else {
            return Ok(());
        };
        let c: Vec<&str> = line.split(',').collect();
        let at = FileNumbers::at(path, n);
        if c.len() != head.len() {
            return Err(at.error("", format!("{} fields, the header has {}", c.len(), head.len())));
        }
        let num = |k: usize| Number::Text(c[k]);
        let code = at.count("kind", num(kind), (0, 255))? as u8;
        let Some(k) = Kind::from_code(code) else {
            return Err(at.error("kind", format!("{code} is not a particle kind of hsph (0 to 4)")));
        };
        let body_i = at.count("body", num(body), (0, u16::MAX as u64))? as u16;
        let any = (f64::MIN, f64::MAX);
        let mut pos = Vector::<D>::zeros();
        for a in 0..D {
            pos[a] = at.real(AXES[a], num(x + a), any)?;
        }
        let id_v = at.count("id", num(id), (0, 1u64 << 53))?;
        let mut r = Record::new(id_v, k, body_i, 0, pos, Vector::zeros(), 0.0, 0.0);
        if let Some(fl) = failed {
            r.failed = at.count("failed", num(fl), (0, u16::MAX as u64))? as u16;
        }
        out.p.push_owned(r);
        // the colouring column may hold a NaN; the colour scale leaves it out
        out.values.push(c[f].parse().unwrap_or(f64::NAN));
        Ok(())
    })?;
    match cols {
        Some(_) => Ok(()),
        None => Err(not_final()),
    }
}

/// Colour scale of `values` between the quantiles `q` (e.g. 5th to 95th percentile, so that
/// a few extreme particles do not wash the picture out).
pub(super) fn scale(values: &[f64], q: (f64, f64)) -> (f64, f64) {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (0.0, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(q.0), at(q.1));
    if hi > lo {
        (lo, hi)
    } else {
        (lo, lo + 1.0)
    }
}
