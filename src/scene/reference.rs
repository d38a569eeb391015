//! The reference a run is checked against (`[reference]`): which analytic solution or
//! experiment, its parameters and their checks. The errors are computed in `crate::reference`.

use super::checks::*;
use super::*;
use crate::error::Result;
use crate::limits::MAX_SPEED;
use serde::{Deserialize, Serialize};

/// An analytic or tabulated reference the run is checked against; the named relative errors
/// (fractions) land in `summary.json` under `errors`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum Reference {
    /// Morris et al. (1997) body-force-driven start-up between plates at y = 0 and y = gap.
    Poiseuille {
        /// Plate gap L (m).
        gap: f64,
        /// Times (s) at which the error is measured (the first step at or after each).
        times: Vec<f64>,
    },
    /// Impulsively started Couette flow; the upper plate's speed is the reference `v0`.
    Couette {
        /// Plate gap L (m).
        gap: f64,
        /// Upper plate speed v0 (m/s).
        v0: f64,
        /// Times (s).
        times: Vec<f64>,
    },
    /// Still water: p = ρ0 g (H − y) with the free surface at `surface`.
    Hydrostatic {
        /// Free-surface height (m) along the last axis.
        surface: f64,
        /// Bottom height (m) of the fluid.
        bottom: f64,
    },
    /// A measured hole (an impact experiment): the hole probe's settled axes are compared
    /// with `major` and `minor` (m) in `summary.json`.
    Hole {
        /// Major axis of the experiment's hole (m).
        major: f64,
        /// Minor axis (m).
        minor: f64,
        /// Where the figures come from.
        #[serde(default)]
        source: String,
    },
    /// Lid-driven square cavity (2D) against Ghia, Ghia & Shin (1982): u on the vertical and
    /// v on the horizontal centreline at their interior tabulated points, in lid-speed units.
    Cavity {
        /// Reynolds number U L/ν of the reference: 100, 400 or 1000 (Ghia's tables) or 1 (a
        /// finite-difference Stokes solution, [`crate::stokes_cavity`]).
        re: u32,
        /// Lid speed U (m/s), along +x.
        lid_speed: f64,
        /// Side L (m).
        size: f64,
        /// Lower-left corner of the cavity (m).
        #[serde(default = "zero2")]
        origin: Vec<f64>,
    },
    /// A solitary wave made by the scene's `solitary` wave maker: the crest at one gauge
    /// against the wave height A, the crest's arrival at another against the celerity
    /// √(g (h + A)), and the maximum run-up at a wall gauge against Su & Mirie (1980),
    /// R/h = 2α + α²/2 + 3α³/4 with α = A/h ([`crate::reference::su_mirie_runup`]).
    SolitaryWave {
        /// Gauge probe whose crest is compared with A (seed 002: 2 m from the paddle).
        crest_gauge: String,
        /// Gauge probe whose crest time is compared with the celerity's (seed 002: 8 m).
        arrival_gauge: String,
        /// Gauge probe at the wall the wave runs up.
        runup_gauge: String,
    },
    /// The decaying Taylor–Green vortex in a periodic square of side L (docs/analytic.md §2):
    /// u = −U e^{bt} cos(2πx/L) sin(2πy/L), v = U e^{bt} sin(2πx/L) cos(2πy/L),
    /// b = −8π²ν/L², with the domain's lower corner at the origin of x and y.
    TaylorGreen {
        /// U (m/s).
        speed: f64,
        /// L (m).
        length: f64,
        /// Times (s) at which the error and the particle disorder are measured.
        times: Vec<f64>,
    },
    /// Wall pressure at impact against a dam-break experiment compiled into hsph
    /// (`crate::reference::wall_pressure`): each named pressure probe's loads (docs/pressure.md
    /// §1) against the experiment's sensor of the same name, over the experiment's own time
    /// window, both through one code. Errors `<probe>_peak` (filtered peak) and
    /// `<probe>_impulse` (first impact's impulse) land in `summary.json`.
    WallPressure {
        /// The experiment.
        experiment: PressureExperiment,
        /// Pressure probes compared, by name (each one of the experiment's sensors).
        sensors: Vec<String>,
    },
    /// Koshizuka & Oka (1996) surge front Z = z/L vs T = t·sqrt(2g/L), experiment.
    DamBreakFront {
        /// Column width L (m).
        column_width: f64,
        /// Left wall position (m) from which the front is measured.
        origin: f64,
    },
}

/// The dam-break wall-pressure experiments compiled into hsph (`inputs/reference/`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PressureExperiment {
    /// Lobovsky et al. (2014), H = 300 mm: the 20 kHz run of sensors S1–S4.
    Lobovsky2014H300,
    /// Buchner (2002), H = 0.6 m: P1 and P2 digitised from a figure (no filter applies).
    Buchner2002,
}

/// One sensor of a wall-pressure experiment: its name (the probe's), its series' column in
/// the experiment's file (`source/sensor` for a long table), and the window [from, to] in
/// t√(g/H) its loads are read over.
#[derive(Debug, Clone, Copy)]
pub struct ExperimentSensor {
    /// Name, as the compared probe's.
    pub name: &'static str,
    /// Column of the experiment's series.
    pub column: &'static str,
    /// The window in t√(g/H).
    pub window: (f64, f64),
}

/// What a wall-pressure experiment is, as hsph compares with it: its water depth H (m), its
/// sensors, and its own filter (s; `None`: the probe's, for a measured series; `Some(0)`: none,
/// for curves digitised from a figure).
#[derive(Debug, Clone, Copy)]
pub struct ExperimentProtocol {
    /// H (m).
    pub depth: f64,
    /// The sensors.
    pub sensors: &'static [ExperimentSensor],
    /// The experiment's filter.
    pub filter: Option<f64>,
}

const LOBOVSKY_SENSORS: &[ExperimentSensor] = &[
    ExperimentSensor {
        name: "S1",
        column: "p_sensor1_3mm",
        window: (0.0, 4.5),
    },
    ExperimentSensor {
        name: "S2",
        column: "p_sensor2_15mm",
        window: (0.0, 4.5),
    },
    ExperimentSensor {
        name: "S3",
        column: "p_sensor3_30mm",
        window: (0.0, 4.5),
    },
    // the hump, not a spike before it (issue 82)
    ExperimentSensor {
        name: "S4",
        column: "p_sensor4_80mm",
        window: (2.0, 4.5),
    },
];

const BUCHNER_SENSORS: &[ExperimentSensor] = &[
    ExperimentSensor {
        name: "P1",
        column: "trixi/P1",
        window: (2.3, 3.5),
    },
    ExperimentSensor {
        name: "P1_low",
        column: "trixi/P1",
        window: (2.3, 3.5),
    },
    ExperimentSensor {
        name: "P2",
        column: "trixi/P2",
        window: (4.5, 6.5),
    },
];

impl PressureExperiment {
    /// Its protocol: depth, sensors, filter.
    pub fn protocol(self) -> ExperimentProtocol {
        match self {
            PressureExperiment::Lobovsky2014H300 => ExperimentProtocol {
                depth: 0.3,
                sensors: LOBOVSKY_SENSORS,
                filter: None,
            },
            PressureExperiment::Buchner2002 => ExperimentProtocol {
                depth: 0.6,
                sensors: BUCHNER_SENSORS,
                filter: Some(0.0),
            },
        }
    }

    /// The names of its sensors (what `reference.sensors` may name).
    pub fn sensor_names(self) -> Vec<&'static str> {
        self.protocol().sensors.iter().map(|s| s.name).collect()
    }
}

/// Default corner of a cavity reference.
fn zero2() -> Vec<f64> {
    vec![0.0, 0.0]
}

pub(super) fn validate_reference(s: &Scene) -> Result<()> {
    let Some(r) = &s.reference else { return Ok(()) };
    let times = match r {
        Reference::Poiseuille { gap, times } | Reference::Couette { gap, times, .. } => {
            check_channel(s, r, *gap)?;
            times.as_slice()
        }
        Reference::TaylorGreen { speed, length, times } => {
            check_taylor_green(s, *speed, *length)?;
            times.as_slice()
        }
        Reference::Hydrostatic { surface, bottom } => {
            if surface <= bottom {
                return err("reference.surface", "must lie above reference.bottom");
            }
            &[]
        }
        Reference::DamBreakFront { column_width, .. } => {
            positive(*column_width, "reference.column_width", "column_width = 0.146")?;
            &[]
        }
        Reference::Cavity {
            re,
            lid_speed,
            size,
            origin,
        } => {
            check_cavity(s, *re, (*lid_speed, *size), origin)?;
            &[]
        }
        Reference::SolitaryWave {
            crest_gauge,
            arrival_gauge,
            runup_gauge,
        } => {
            validate_solitary_reference(s, [crest_gauge, arrival_gauge, runup_gauge])?;
            &[]
        }
        Reference::WallPressure { experiment, sensors } => {
            validate_wall_pressure(s, *experiment, sensors)?;
            &[]
        }
        Reference::Hole { major, minor, .. } => {
            positive(*major, "reference.major", "major = 0.0106")?;
            positive(*minor, "reference.minor", "minor = 0.0085")?;
            if !s.probes.iter().any(|p| p.hole_bodies().is_some()) {
                return err(
                    "reference",
                    "a hole reference needs a [[probe]] of kind = \"hole\"",
                );
            }
            &[]
        }
    };
    for (j, t) in times.iter().enumerate() {
        if !(*t > 0.0 && *t <= s.time.t_end) {
            return err(
                format!("reference.times[{j}]"),
                format!("must lie in (0, time.t_end = {}], got {t}", s.time.t_end),
            );
        }
    }
    Ok(())
}

/// Poiseuille and Couette start-ups: a positive gap (m), a plate speed within the limits
/// (Couette), a laminar viscosity.
fn check_channel(s: &Scene, r: &Reference, gap: f64) -> Result<()> {
    positive(gap, "reference.gap", "gap = 1e-3")?;
    if let Reference::Couette { v0, .. } = r {
        in_range(
            *v0,
            "reference.v0",
            (-MAX_SPEED, MAX_SPEED),
            "m/s",
            "MAX_SPEED",
            "v0 = 2.5e-5",
        )?;
    }
    if s.physics.laminar_viscosity <= 0.0 {
        return err(
            "physics.laminar_viscosity",
            "the Poiseuille/Couette references need a laminar viscosity ν > 0",
        );
    }
    Ok(())
}

/// The Taylor–Green vortex: a speed (m/s) and length (m), in a 2D box periodic in x and y.
fn check_taylor_green(s: &Scene, speed: f64, length: f64) -> Result<()> {
    positive(speed, "reference.speed", "speed = 1.0")?;
    in_range(
        speed,
        "reference.speed",
        (0.0, MAX_SPEED),
        "m/s",
        "MAX_SPEED",
        "speed = 1.0",
    )?;
    positive(length, "reference.length", "length = 1.0")?;
    if s.dimension != 2 || s.domain.periodic.iter().take(2).any(|p| !p) {
        return err(
            "reference",
            "the Taylor–Green reference is a 2D vortex in a box periodic in x and y: \
             dimension = 2 and domain.periodic = [true, true]",
        );
    }
    Ok(())
}

/// The lid-driven cavity: a Reynolds number with a table, a size (m), a non-zero lid speed
/// (m/s), 2D.
fn check_cavity(s: &Scene, re: u32, (lid_speed, size): (f64, f64), origin: &[f64]) -> Result<()> {
    if ![1, 100, 400, 1000].contains(&re) {
        return err(
            "reference.re",
            format!(
                "the cavity references are Ghia, Ghia & Shin's tables for Re = 100, 400 and 1000 \
                 and a Stokes solution for Re = 1, not {re}; use re = 100"
            ),
        );
    }
    positive(size, "reference.size", "size = 1.0")?;
    if !(lid_speed.is_finite() && lid_speed != 0.0) {
        return err(
            "reference.lid_speed",
            "must be a non-zero speed (m/s), e.g. lid_speed = 1.0",
        );
    }
    if s.dimension != 2 || origin.len() != 2 {
        return err(
            "reference",
            "the cavity reference is 2D: dimension = 2 and origin = [x, y]",
        );
    }
    Ok(())
}

/// A solitary-wave reference needs the `solitary` wave maker and three gauge probes by name:
/// the crest, arrival and run-up gauges, in that order.
fn validate_solitary_reference(s: &Scene, gauges: [&String; 3]) -> Result<()> {
    if !s
        .walls
        .iter()
        .any(|w| matches!(w.motion, Some(Motion::Solitary { .. })))
    {
        return err(
            "reference",
            "a solitary_wave reference needs a wall with motion = { law = \"solitary\", \
             amplitude = …, depth = … } (the wave maker)",
        );
    }
    for (key, name) in ["crest_gauge", "arrival_gauge", "runup_gauge"]
        .into_iter()
        .zip(gauges)
    {
        if !s
            .probes
            .iter()
            .any(|p| p.gauge_point().is_some() && p.name() == name)
        {
            let gauges: Vec<&str> = s
                .probes
                .iter()
                .filter(|p| p.gauge_point().is_some())
                .map(|p| p.name())
                .collect();
            return err(
                format!("reference.{key}"),
                format!("no [[probe]] of kind = \"gauge\" is named {name:?}; the gauges are {gauges:?}"),
            );
        }
    }
    Ok(())
}

/// A wall-pressure reference names pressure probes of the scene, each one of the experiment's
/// sensors.
fn validate_wall_pressure(s: &Scene, experiment: PressureExperiment, sensors: &[String]) -> Result<()> {
    let known = experiment.sensor_names();
    if sensors.is_empty() {
        return err(
            "reference.sensors",
            format!("name at least one pressure probe; the experiment's sensors are {known:?}"),
        );
    }
    for (k, name) in sensors.iter().enumerate() {
        if !known.contains(&name.as_str()) {
            return err(
                format!("reference.sensors[{k}]"),
                format!("{name:?} is not a sensor of this experiment; its sensors are {known:?}"),
            );
        }
        if !s
            .probes
            .iter()
            .any(|p| p.name() == name && p.load_rules().is_some())
        {
            return err(
                format!("reference.sensors[{k}]"),
                format!("no [[probe]] of kind = \"pressure\" is named {name:?}"),
            );
        }
    }
    Ok(())
}
