//! Initial fields by expression (`[[fluid]] velocity_field`, `pressure_field`): text such as
//! `"-U*cos(PI*x/L)*sin(PI*y/L)"` parsed once by the `exmex` crate and evaluated at every
//! lattice site of the body.
//!
//! Names an expression may use: the coordinates `x`, `y` (and `z` in 3D) in m, the scene's
//! `[constants]`, and exmex's constants `PI` (also `π`), `TAU` (`τ`), `E` (`e`). Functions:
//! `sin`, `cos`, `tan`, `asin`, `acos`, `atan`, `sinh`, `cosh`, `tanh`, `asinh`, `acosh`,
//! `atanh`, `exp`, `ln` (also `log`), `log10`, `log2`, `sqrt`, `cbrt`, `abs`, `signum`, `floor`,
//! `ceil`, `round`, `trunc`, `fract`, and of two arguments `min(a, b)`, `max(a, b)`,
//! `atan2(y, x)`; operators `+ - * / ^`. Any other name, bad syntax, or a value that is not
//! finite somewhere in the body is an input error (exit 2) naming the key.
//!
//! A `[constants]` name must be one an expression reads as one name ([`constant_name`]): not a
//! coordinate nor a built-in name in any letter case (exmex's own win, so `PI = 3.0` or
//! `E = 70e9` would be ignored), and not starting with `min`, `max` or `atan2` (exmex reads
//! `max_u` as `max` and `_u`).
//!
//! Each expression is bounded before it is parsed (`check_size`): the parser's time grows
//! faster than the text ([`crate::limits::MAX_EXPR_CHARS`], [`crate::limits::MAX_EXPR_DEPTH`]).

use crate::error::{Error, Result};
use crate::limits::{MAX_EXPR_CHARS, MAX_EXPR_DEPTH};
use exmex::prelude::*;
use exmex::{literal_matcher_from_pattern, FloatOpsFactory, MakeOperators, MatchLiteral, Operator};

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

/// The names exmex gives a meaning of its own, functions and constants, from its operator
/// table (`+ - * / ^` left out): the list a constant may not shadow.
pub fn builtin_names() -> Vec<&'static str> {
    named_operators().iter().map(|op| op.repr()).collect()
}

/// exmex's operators with a name (functions and constants), not a sign.
fn named_operators() -> Vec<Operator<'static, f64>> {
    let mut ops = FloatOpsFactory::<f64>::make();
    ops.retain(|op| op.repr().chars().all(|c| c.is_alphanumeric() || c == '_'));
    ops
}

/// The coordinates an expression reads (m); a constant may not take their names.
pub const COORDINATES: [&str; 3] = ["x", "y", "z"];

/// True for a character exmex accepts in a name: Latin or Greek letters, `_`, and after the
/// first, digits (its pattern `[a-zA-Zα-ωΑ-Ω_]+[a-zA-Zα-ωΑ-Ω_0-9]*`).
fn name_char(c: char, first: bool) -> bool {
    c.is_ascii_alphabetic()
        || c == '_'
        || ('α'..='ω').contains(&c)
        || ('Α'..='Ω').contains(&c)
        || (!first && c.is_ascii_digit())
}

/// Why `name` cannot be a `[constants]` name, if it cannot: expressions could not name it,
/// or it is (in any letter case) a coordinate or one of exmex's built-in names, which win over
/// a variable of the same name, or exmex would read it as a two-argument function and the
/// rest.
pub fn constant_name(name: &str) -> std::result::Result<(), String> {
    let mut chars = name.chars();
    let well_formed = chars.next().is_some_and(|c| name_char(c, true)) && chars.all(|c| name_char(c, false));
    if !well_formed {
        return Err(format!(
            "`{name}` is not a name an expression can use: Latin or Greek letters, digits and _, not \
             starting with a digit; e.g. U_0"
        ));
    }
    let lower = name.to_lowercase();
    if let Some(c) = COORDINATES.iter().find(|c| **c == lower) {
        return Err(format!(
            "`{name}` is the coordinate `{c}` of expressions (m): a constant may not take its name; e.g. {name}_0"
        ));
    }
    let ops = named_operators();
    if let Some(op) = ops.iter().find(|op| op.repr().to_lowercase() == lower) {
        let b = op.repr();
        let what = if op.constant().is_some() {
            "constant"
        } else {
            "function"
        };
        let how = if b == name {
            "the built-in wins, so this constant would be ignored"
        } else {
            "a constant of the same name in another letter case would be confused with it"
        };
        return Err(format!(
            "`{name}` is the built-in {what} `{b}` of expressions ({how}); name it otherwise, e.g. {name}_0"
        ));
    }
    if let Some(op) = ops.iter().find(|op| op.has_bin() && name.starts_with(op.repr())) {
        let capital: String = name[..1].to_uppercase() + &name[1..];
        return Err(format!(
            "`{name}` starts with the two-argument function `{}`, and expressions would read it as \
             that function followed by `{}`; e.g. {capital}",
            op.repr(),
            &name[op.repr().len()..]
        ));
    }
    Ok(())
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

    #[test]
    fn constants_may_not_take_the_names_expressions_already_know() {
        for name in [
            "U", "L", "RHO", "U_0", "pix", "e2", "ν", "t", "x0", "sinx", "Maxim",
        ] {
            assert!(constant_name(name).is_ok(), "{name}");
        }
        let refused = [
            ("PI", "`PI`"),
            ("pi", "`PI`"),
            ("Pi", "`PI`"),
            ("E", "`E`"),
            ("e", "`e`"),
            ("TAU", "`TAU`"),
            ("tau", "`TAU`"),
            ("π", "`π`"),
            ("Π", "`π`"),
            ("sin", "`sin`"),
            ("SQRT", "`sqrt`"),
            ("log", "`log`"),
            ("atan2", "`atan2`"),
            ("x", "coordinate"),
            ("Z", "coordinate"),
            ("max_u", "`max`"),
            ("minor", "`min`"),
            ("2U", "not a name"),
            ("a-b", "not a name"),
            ("", "not a name"),
        ];
        for (name, why) in refused {
            let e = constant_name(name).unwrap_err();
            assert!(e.contains(why), "{name}: {e}");
        }
        // every function and constant exmex knows is refused, so none can be shadowed silently
        for b in builtin_names() {
            assert!(constant_name(b).is_err(), "{b}");
            assert!(constant_name(&b.to_uppercase()).is_err(), "{b}");
        }
        assert!(builtin_names().len() > 30);
    }
}
