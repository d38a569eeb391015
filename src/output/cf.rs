//! The CF point layout both netCDF writers share (`netcdf.rs` classic, `netcdf4.rs` HDF5):
//! a snapshot piece's variables along `particle`, their units and long names, the time
//! coordinate's attributes and the global attributes.

use super::snapshot::Piece;
use crate::particles::{Column, Particles};

/// Attributes of the `time` variable (CF: a time coordinate in seconds).
pub(crate) const TIME_ATTRS: [(&str, &str); 4] = [
    ("standard_name", "time"),
    ("long_name", "simulated time"),
    ("units", "s"),
    ("axis", "T"),
];

/// CF conventions version the files follow.
pub const CONVENTIONS: &str = "CF-1.8";

/// A variable's values before they are written.
#[derive(Clone)]
pub(crate) enum Values {
    /// Small codes (particle kinds).
    I8(Vec<i8>),
    /// Indices.
    I32(Vec<i32>),
    /// Ids (netCDF-3 has no 64-bit integers: written as int below 2³¹, else as double).
    U64(Vec<u64>),
    /// Reals.
    F64(Vec<f64>),
}

/// A variable along `particle`: name, values, units, long name.
pub(crate) struct Var {
    pub name: String,
    pub values: Values,
    pub unit: String,
    pub long_name: String,
}

/// What one snapshot piece holds, whatever the file format: global attributes, the variables
/// along `particle`, the `coordinates` attribute of data variables, time (s) and step.
pub(crate) struct PieceData {
    pub global: Vec<(&'static str, String)>,
    pub vars: Vec<Var>,
    pub coordinates: &'static str,
    pub t: f64,
    pub step: u64,
    pub n: usize,
}

/// The variables of one column of `p` in `order` (a vector gives one per component).
fn column_vars<const D: usize>(
    col: &Column<D>,
    stem: &str,
    unit: &str,
    long: &str,
    order: &[usize],
) -> Vec<Var> {
    let var = |name: String, long_name: String, values| Var {
        name,
        values,
        unit: unit.to_string(),
        long_name,
    };
    match col {
        Column::Vector(_) => (0..D)
            .map(|a| {
                let axis = ["x", "y", "z"][a];
                let v = order.iter().map(|&i| col.value(i, a)).collect();
                var(
                    format!("{stem}_{axis}"),
                    format!("{long}, {axis} component"),
                    Values::F64(v),
                )
            })
            .collect(),
        Column::Tensor(_) => (0..col.components())
            .map(|k| {
                let (r, c) = crate::particles::value::tensor_component::<D>(k);
                let comp = format!("{}{}", ["x", "y", "z"][r], ["x", "y", "z"][c]);
                let v = order.iter().map(|&i| col.value(i, k)).collect();
                var(
                    format!("{stem}_{comp}"),
                    format!("{long}, {comp} component"),
                    Values::F64(v),
                )
            })
            .collect(),
        Column::Kind(k) => {
            let v = order.iter().map(|&i| k[i].code() as i8).collect();
            vec![var(stem.into(), long.into(), Values::I8(v))]
        }
        Column::U16(u) => {
            let v = order.iter().map(|&i| i32::from(u[i])).collect();
            vec![var(stem.into(), long.into(), Values::I32(v))]
        }
        Column::U64(u) => {
            let v = order.iter().map(|&i| u[i]).collect();
            vec![var(stem.into(), long.into(), Values::U64(v))]
        }
        Column::F64(_) => {
            let v = order.iter().map(|&i| col.value(i, 0)).collect();
            vec![var(stem.into(), long.into(), Values::F64(v))]
        }
    }
}

/// One rank's snapshot piece in the CF point layout (see the module documentation).
pub(crate) fn piece_data<const D: usize>(piece: &Piece<D>, fields: &[String]) -> PieceData {
    let p = piece.p;
    let order = &piece.order;
    let table = Particles::<D>::field_table();
    let per_depth = if D == 2 { " m-1" } else { "" };
    let mut vars = Vec::new();
    for (a, axis) in ["x", "y", "z"][..D].iter().enumerate() {
        vars.push(Var {
            name: axis.to_string(),
            values: Values::F64(order.iter().map(|&i| p.x[i][a]).collect()),
            unit: "m".into(),
            long_name: format!("position, {axis} component"),
        });
    }
    let id_meta = table.iter().find(|m| m.name == "id").expect("the table has ids");
    vars.extend(column_vars(
        &Column::<D>::U64(&p.id),
        "id",
        id_meta.unit,
        id_meta.long_name,
        order,
    ));
    for name in fields {
        if let Some(m) = table.iter().find(|m| m.snapshot == Some(name.as_str())) {
            let col = p.column(m.name).expect("a table field has a column");
            let unit = if m.name == "mass" {
                format!("{}{per_depth}", m.unit)
            } else {
                m.unit.to_string()
            };
            vars.extend(column_vars(&col, name, &unit, m.long_name, order));
        }
    }
    let global = vec![
        ("title", piece.scene.name.clone()),
        ("Conventions", CONVENTIONS.to_string()),
        ("featureType", "point".to_string()),
        ("source", source()),
        (
            "piece",
            format!(
                "rank {} of {}: its owned particles in id order; the snapshot is every piece \
                 concatenated along `particle`",
                piece.rank, piece.ranks
            ),
        ),
    ];
    PieceData {
        global,
        vars,
        coordinates: ["time x", "time x y", "time x y z"][D - 1],
        t: piece.t,
        step: piece.step,
        n: piece.order.len(),
    }
}

/// `hsph <version> (<commit>)`.
pub(crate) fn source() -> String {
    format!("hsph {} ({})", env!("CARGO_PKG_VERSION"), env!("HSPH_GIT_COMMIT"))
}
