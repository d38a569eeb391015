//! Initial fields by expression (`[[fluid]] velocity_field`, `pressure_field`): text such as
//! `"-U*cos(PI*x/L)*sin(PI*y/L)"` parsed once by the `exmex` crate and evaluated at every
//! lattice site of the body.
//!
//! Names an expression may use: the coordinates `x`, `y` (and `z` in 3D) in m, the scene's
//! `[constants]`, and exmex's constants `PI` (also `π`), `TAU`, `E`. Functions: `sin`, `cos`,
//! `tan`, `asin`, `acos`, `atan`, `sinh`, `cosh`, `tanh`, `exp`, `ln`, `log10`, `log2`, `sqrt`,
//! `abs`, `signum`, `floor`, `ceil`, `round`, `fract`, `cbrt`, operators `+ - * / ^`. Any other
//! name, bad syntax, or a value that is not finite somewhere in the body is an input error
//! (exit 2) naming the key.

use crate::error::{Error, Result};
use crate::limits::{MAX_EXPR_CHARS, MAX_EXPR_DEPTH};
use exmex::prelude::*;
use exmex::{literal_matcher_from_pattern, FloatOpsFactory, MatchLiteral};

// Number literals with an optional exponent (`2.0e5`, `1e-3`): exmex's default matcher stops
// at the `e`, which made `-2.0e5` an error.
literal_matcher_from_pattern!(Scientific, r"^([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?");

/// The expressions of a scene: f64 with the usual operators and scientific literals.
type Expr = FlatEx<f64, FloatOpsFactory<f64>, Scientific>;
use std::collections::BTreeMap;

/// Where each variable of a parsed expression comes from.
#[derive(Debug, Clone, Copy)]
enum Slot {
    /// Coordinate along axis `a`.
    Coord(usize),
    /// A scene constant.
    Const(f64),
}

/// A parsed expression of the coordinates and the scene's constants.
#[derive(Debug, Clone)]
pub struct FieldExpr {
    key: String,
    text: String,
    expr: Expr,
    slots: Vec<Slot>,
}

impl FieldExpr {
    /// Parse `text` (the value of scene key `key`) for a `dim`-dimensional scene with
    /// `constants`.
    pub fn parse(key: &str, text: &str, dim: usize, constants: &BTreeMap<String, f64>) -> Result<Self> {
        check_size(key, text)?;
        let expr = Expr::parse(text).map_err(|e| {
            Error::input(
                key,
                format!("cannot parse `{}`: {}", shown(text), shown(&e.to_string())),
            )
        })?;
        let axes = &["x", "y", "z"][..dim];
        let mut slots = Vec::new();
        for name in expr.var_names() {
            if let Some(a) = axes.iter().position(|c| c == name) {
                slots.push(Slot::Coord(a));
            } else if let Some(v) = constants.get(name.as_str()) {
                slots.push(Slot::Const(*v));
            } else {
                let mut known: Vec<String> = axes.iter().map(|s| s.to_string()).collect();
                known.extend(constants.keys().cloned());
                known.extend(["PI", "TAU", "E"].map(String::from));
                return Err(Error::input(
                    key,
                    format!(
                        "unknown name `{name}` in `{}`; names: {} (add it to [constants], e.g. `{name} = 1.0`)",
                        shown(text),
                        known.join(", ")
                    ),
                ));
            }
        }
        Ok(FieldExpr {
            key: key.to_string(),
            text: text.to_string(),
            expr,
            slots,
        })
    }

    /// The value at position `x` (m); an error naming the key if it is not finite there.
    pub fn eval(&self, x: &[f64]) -> Result<f64> {
        // set-up, not a hot loop: one small vector per site
        let args: Vec<f64> = self.slots.iter().map(|s| self.value(*s, x)).collect();
        let v = self
            .expr
            .eval(&args)
            .map_err(|e| Error::input(&self.key, format!("cannot evaluate `{}`: {e}", shown(&self.text))))?;
        if !v.is_finite() {
            return Err(Error::input(
                &self.key,
                format!(
                    "`{}` is {v} at {:?}: an initial field must be finite in the whole body",
                    shown(&self.text),
                    x
                ),
            ));
        }
        Ok(v)
    }

    fn value(&self, s: Slot, x: &[f64]) -> f64 {
        match s {
            Slot::Coord(a) => x[a],
            Slot::Const(v) => v,
        }
    }
}

/// Bound an expression before it is parsed (the parser's time grows faster than its length):
/// at most [`MAX_EXPR_CHARS`] characters and [`MAX_EXPR_DEPTH`] nested brackets.
pub(crate) fn check_size(key: &str, text: &str) -> Result<()> {
    let chars = text.chars().count();
    if chars > MAX_EXPR_CHARS {
        return Err(Error::input(
            key,
            format!(
                "the expression `{}` is {chars} characters long, above the limit of {MAX_EXPR_CHARS} \
                 (limits::MAX_EXPR_CHARS); name its parts in [constants] or simplify it",
                shown(text)
            ),
        ));
    }
    let (mut depth, mut deepest) = (0usize, 0usize);
    for c in text.chars() {
        match c {
            '(' | '[' | '{' => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            ')' | ']' | '}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    if deepest > MAX_EXPR_DEPTH {
        return Err(Error::input(
            key,
            format!(
                "the expression `{}` nests brackets {deepest} deep, above the limit of {MAX_EXPR_DEPTH} \
                 (limits::MAX_EXPR_DEPTH); flatten it, e.g. sin(x)*cos(y) rather than sin(cos(sin(…)))",
                shown(text)
            ),
        ));
    }
    Ok(())
}

/// `text` for a message: whole up to 80 characters, else its first 60 and the count left out.
fn shown(text: &str) -> String {
    let n = text.chars().count();
    if n <= 80 {
        return text.to_string();
    }
    let head: String = text.chars().take(60).collect();
    format!("{head}… ({} more characters)", n - 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_see_coordinates_and_constants_and_name_what_is_wrong() {
        let c: BTreeMap<String, f64> = [("U".to_string(), 2.0), ("L".to_string(), 0.5)].into();
        let f = FieldExpr::parse("fluid[0].velocity_field[0]", "-U*cos(PI*x/L)*sin(PI*y/L)", 2, &c).unwrap();
        let (x, y) = (0.1_f64, 0.2_f64);
        let want = -2.0 * (std::f64::consts::PI * x / 0.5).cos() * (std::f64::consts::PI * y / 0.5).sin();
        assert!((f.eval(&[x, y]).unwrap() - want).abs() < 1e-15);
        // z is not a coordinate in 2D
        let e = FieldExpr::parse("k", "z + 1", 2, &c).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("unknown name `z`"), "{e}");
        let e = FieldExpr::parse("k", "sin(x", 2, &c).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("cannot parse"), "{e}");
        // scientific literals, also after a unary minus
        let f = FieldExpr::parse("k", "-2.0e5 + 1E-3*x + 3e2", 2, &c).unwrap();
        assert_eq!(f.eval(&[1.0, 0.0]).unwrap(), -2.0e5 + 1e-3 + 300.0);
        let f = FieldExpr::parse("k", "ln(x)", 2, &c).unwrap();
        let e = f.eval(&[0.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("must be finite"), "{e}");
        // constant expressions and many variables
        assert_eq!(
            FieldExpr::parse("k", "3", 3, &c)
                .unwrap()
                .eval(&[0.0; 3])
                .unwrap(),
            3.0
        );
    }

    #[test]
    fn long_or_deep_expressions_are_refused_before_parsing() {
        let c = BTreeMap::new();
        let t = std::time::Instant::now();
        let deep = format!("{}x{}", "sin(".repeat(200_000), ")".repeat(200_000));
        let long = vec!["x"; 100_000].join("+");
        for (text, what) in [(&deep, "characters long"), (&long, "characters long")] {
            let e = FieldExpr::parse("k", text, 2, &c).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().contains(what), "{e}");
            assert!(
                e.to_string().len() < 400,
                "the message quotes the whole text: {e}"
            );
        }
        let nest = |n: usize| format!("{}x{}", "(".repeat(n), ")".repeat(n));
        assert!(FieldExpr::parse("k", &nest(MAX_EXPR_DEPTH), 2, &c).is_ok());
        let e = FieldExpr::parse("k", &nest(MAX_EXPR_DEPTH + 1), 2, &c).unwrap_err();
        assert!(e.to_string().contains("nests brackets"), "{e}");
        let longest = vec!["x"; MAX_EXPR_CHARS / 2].join("+");
        assert!(longest.len() < MAX_EXPR_CHARS);
        assert!(FieldExpr::parse("k", &longest, 2, &c).is_ok());
        assert!(t.elapsed().as_secs_f64() < 2.0, "{:?}", t.elapsed());
    }
}
