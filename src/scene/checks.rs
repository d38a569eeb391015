//! The value checks every part of scene validation shares: one wording for a missing,
//! non-positive or out-of-range number, naming the key, the value, the range and an example.

use crate::error::{Error, Result};

/// An input error at `key`.
pub(super) fn err<T>(key: impl Into<String>, msg: impl Into<String>) -> Result<T> {
    Err(Error::input(key, msg))
}

/// `x` must be a finite number > 0.
pub(super) fn positive(x: f64, key: &str, example: &str) -> Result<()> {
    if !(x > 0.0 && x.is_finite()) {
        return err(
            key,
            format!("must be a positive number (got {x}); e.g. {example}"),
        );
    }
    Ok(())
}

/// `x` must be a finite number ≥ 0.
pub(super) fn non_negative(x: f64, key: &str) -> Result<()> {
    if !(x >= 0.0 && x.is_finite()) {
        return err(key, format!("must be ≥ 0 (got {x})"));
    }
    Ok(())
}

/// `x` as a scene would write it, short at any magnitude: `0.3`, `2000`, `1e5`, `1e-300`.
pub(super) fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-3..1e5).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// `x` (in `unit`) must lie in `[lo, hi]`, the physical range `name` of `src/limits.rs`;
/// NaN and infinities never do. The message names the value, the range and `example`.
pub(super) fn in_range(
    x: f64,
    key: &str,
    (lo, hi): (f64, f64),
    unit: &str,
    name: &str,
    example: &str,
) -> Result<()> {
    if x >= lo && x <= hi {
        return Ok(());
    }
    // no unit: dimensionless
    let u = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    err(
        key,
        format!(
            "{}{u} lies outside [{}, {}]{u}, the range hsph accepts ({name}); e.g. {example}",
            num(x),
            num(lo),
            num(hi)
        ),
    )
}
