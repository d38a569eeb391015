//! `hsph loads`: the loads of a pressure series in any CSV file (an experiment's run), by the
//! rules `summary.json` applies to a run's pressure probes (`crate::probes::loads`), so that a
//! compare tool reads both sides through one code.

use super::*;

/// `hsph loads`'s flags.
#[derive(clap::Args, Debug)]
pub struct LoadsArgs {
    /// CSV file: a header line, then rows (`#` lines skipped).
    file: PathBuf,
    /// The time column.
    #[arg(long, default_value = "t")]
    time: String,
    /// The pressure column.
    #[arg(long)]
    column: String,
    /// Seconds per unit of the time column (e.g. √(H/g) for t·√(g/H)).
    #[arg(long, default_value_t = 1.0)]
    time_scale: f64,
    /// Pascals per unit of the pressure column (e.g. ρgH for p/(ρgH)).
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// Width of the centred box filter (s; 0 = none).
    #[arg(long, default_value_t = crate::scene::DEFAULT_LOAD_FILTER_S)]
    filter: f64,
    /// Span of the first impact's impulse (s); none without it.
    #[arg(long, value_name = "S")]
    impulse_span: Option<f64>,
    /// Read only the rows from this time on (s, after --time-scale).
    #[arg(long, value_name = "S")]
    from: Option<f64>,
    /// Read only the rows up to this time (s, after --time-scale).
    #[arg(long, value_name = "S")]
    to: Option<f64>,
}

/// `hsph loads`: the loads as JSON on standard output, in seconds and pascals.
pub(super) fn cmd_loads(a: LoadsArgs) -> Result<i32> {
    let positive = |flag: &str, x: f64, zero: bool| -> Result<()> {
        if x.is_finite() && (x > 0.0 || (zero && x == 0.0)) {
            return Ok(());
        }
        let least = if zero { "≥ 0" } else { "> 0" };
        Err(Error::input(
            flag,
            format!("must be a finite number {least}, got {x}"),
        ))
    };
    positive("--time-scale", a.time_scale, false)?;
    positive("--scale", a.scale, false)?;
    positive("--filter", a.filter, true)?;
    if let Some(w) = a.impulse_span {
        positive("--impulse-span", w, false)?;
    }
    let (t, p) = crate::probes::loads::read_csv(&a.file, (&a.time, &a.column), (a.time_scale, a.scale))?;
    let lo = a.from.unwrap_or(f64::NEG_INFINITY);
    let hi = a.to.unwrap_or(f64::INFINITY);
    let (t, p): (Vec<f64>, Vec<f64>) = t.into_iter().zip(p).filter(|(x, _)| *x >= lo && *x <= hi).unzip();
    let Some(loads) = crate::probes::loads::loads(&t, &p, a.filter, a.impulse_span) else {
        return Err(Error::input(
            "--from",
            format!("no row of {} lies in the times asked for", a.file.display()),
        ));
    };
    let text = serde_json::to_string_pretty(&loads).map_err(|e| Error::run(e.to_string()))?;
    println!("{text}");
    Ok(0)
}
