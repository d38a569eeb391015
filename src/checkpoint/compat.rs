//! What a restart may change: the end of the run and how it is written, never the physics.

use crate::error::{Error, Result};
use crate::scene::Scene;

/// Keys a restart may change with `--set` (dotted prefixes).
pub const CHANGEABLE: &[&str] = &[
    "time.t_end",
    "time.max_steps",
    "output.interval",
    "output.fields",
    "output.format",
    "output.gather_limit",
    "checkpoint",
    "description",
];

/// The first key (dotted path) where `a` and `b` differ, outside [`CHANGEABLE`].
fn first_difference(a: &toml::Value, b: &toml::Value, path: &str) -> Option<String> {
    if CHANGEABLE
        .iter()
        .any(|c| path == *c || path.starts_with(&format!("{c}.")))
    {
        return None;
    }
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| {
                let sub = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => first_difference(u, v, &sub),
                    _ => (!CHANGEABLE
                        .iter()
                        .any(|c| sub == *c || sub.starts_with(&format!("{c}."))))
                    .then_some(sub),
                }
            })
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (u, v))| first_difference(u, v, &format!("{path}[{i}]"))),
        _ => (a != b).then(|| path.to_string()),
    }
}

/// Refuse (exit 2) a restarted scene that differs from the checkpoint's outside
/// [`CHANGEABLE`]: the continued run would no longer be the run that was checkpointed.
pub fn check(original: &Scene, restarted: &Scene) -> Result<()> {
    let value = |s: &Scene| toml::Value::try_from(s).map_err(|e| Error::run(format!("scene: {e}")));
    match first_difference(&value(original)?, &value(restarted)?, "") {
        None => Ok(()),
        Some(key) => Err(Error::input(
            key,
            format!(
                "a restart continues the checkpointed run and may change only {}; this change \
                 would alter the physics: start a new run instead",
                CHANGEABLE.join(", ")
            ),
        )),
    }
}
