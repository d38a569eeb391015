//! Probes (`[[probe]]`): what each kind measures, its keys and their checks. The measuring is
//! in `crate::probes`.

use super::checks::*;
use super::*;
use crate::error::Result;

/// A probe (`[[probe]]`), written to `probes/<name>.csv` on its own clock: every `interval`
/// seconds of simulated time (default: at the output steps; 0 = every step), buffered and
/// flushed at output steps. Sensors are documented in `src/probes/sensors.rs`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum Probe {
    /// Pressure transducer at a point, usually on a wall face: the kernel-weighted (Shepard)
    /// average of the fluid pressure around it (walls excluded), averaged over a sensing face
    /// of `diameter` across `normal` and over the last `window` seconds: column `p` (Pa).
    Pressure {
        /// Probe name (file `probes/<name>.csv`).
        name: String,
        /// Centre of the sensing face (m).
        point: Vec<f64>,
        /// Diameter of the sensing face (m; 0 = a point).
        #[serde(default)]
        diameter: f64,
        /// Normal of the sensing face (needed when `diameter` > 0; any length).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        normal: Option<Vec<f64>>,
        /// Averaging window (s; 0 = instantaneous). A windowed sensor samples every step.
        #[serde(default)]
        window: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
        /// Width (s) of the centred box filter of `summary.json`'s loads (default
        /// [`DEFAULT_LOAD_FILTER_S`], 2 ms; 0 = none): `crate::probes::loads`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        filter: Option<f64>,
        /// The span (s) over which `summary.json`'s loads integrate the first impact's impulse
        /// ∫p dt, from the first time p stays above 10 % of the filtered peak for 1 ms (none
        /// without it).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        impulse_span: Option<f64>,
        /// A moving wall (`[[wall]]` with a `motion`) the sensor rides on: its face moves with
        /// the wall's displacement (a slamming body's transducers); none for a fixed sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        body: Option<String>,
    },
    /// Kernel-interpolated velocity at `points` points from `from` to `to`.
    VelocityLine {
        /// Probe name.
        name: String,
        /// Start (m).
        from: Vec<f64>,
        /// End (m).
        to: Vec<f64>,
        /// Number of sample points (≥ 2).
        points: usize,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Wave gauge at a station: the elevation (along the last axis) where the continuous water
    /// column on the bed under `point` ends (interpolated matter fraction ½; spray above it is
    /// ignored), 0 when dry: column `eta`.
    Gauge {
        /// Probe name.
        name: String,
        /// A point on the vertical line (m); its last coordinate is ignored.
        point: Vec<f64>,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Front of the main body of fluid along `axis` in `direction`: the extreme coordinate of
    /// the largest connected group of fluid particles (two particles connect when closer than
    /// `link`·dx), so that detached drops and spray do not count: column `front` (m).
    Front {
        /// Probe name.
        name: String,
        /// Axis index (0 = x).
        #[serde(default)]
        axis: usize,
        /// `"+"` (largest coordinate, the default) or `"-"` (smallest).
        #[serde(default)]
        direction: Direction,
        /// Connection distance in units of dx (default 1.5).
        #[serde(default = "default_link")]
        link: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Force and moment the fluid exerts on the wall `body` (N and N·m; per metre of depth in
    /// 2D), the same pair forces the walls exert on the fluid, reversed; the moment is about
    /// `about`: columns `fx, fy[, fz]` then `mz` (2D) or `mx, my, mz` (3D).
    Force {
        /// Probe name.
        name: String,
        /// Name of a `[[wall]]` with dummy or repulsive particles.
        body: String,
        /// Point the moment is taken about (m; default the origin).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        about: Option<Vec<f64>>,
        /// Averaging window (s; 0 = instantaneous). A windowed sensor samples every step.
        #[serde(default)]
        window: f64,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// The hole a projectile punches through a plate and the debris cloud behind it
    /// (`probes::hole` states the method): columns `perforated`, `major`, `minor` (m), `angle`
    /// (degrees), `area` (m²), `centre_u`, `centre_v` (m), `debris` (particles),
    /// `debris_length`, `debris_width` (m). `summary.json` reports the axes once settled.
    Hole {
        /// Probe name.
        name: String,
        /// The `[[solid]]` plate.
        plate: String,
        /// The `[[solid]]` projectile (its initial velocity is the impact direction).
        projectile: String,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
    /// Test only (`crate::probes::sensors`): the run's fluid mass Σ m_j in id order (kg; per
    /// metre of depth in 2D), column `mass`. It proves the probe recipe of ARCHITECTURE.md: a
    /// kind is this file and `probes/sensors.rs`.
    #[cfg(test)]
    Toy {
        /// Probe name.
        name: String,
        /// Seconds between rows (default: the output interval; 0 = every step).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        interval: Option<f64>,
    },
}

/// The default width (s) of a pressure probe's load filter: a centred 2 ms box.
pub const DEFAULT_LOAD_FILTER_S: f64 = 2e-3;

/// Which way a front probe looks along its axis.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum Direction {
    /// Towards larger coordinates.
    #[default]
    #[serde(rename = "+")]
    Plus,
    /// Towards smaller coordinates.
    #[serde(rename = "-")]
    Minus,
}

fn default_link() -> f64 {
    1.5
}

impl Probe {
    /// The probe's name.
    pub fn name(&self) -> &str {
        match self {
            Probe::Pressure { name, .. }
            | Probe::VelocityLine { name, .. }
            | Probe::Gauge { name, .. }
            | Probe::Front { name, .. }
            | Probe::Force { name, .. }
            | Probe::Hole { name, .. } => name,
            #[cfg(test)]
            Probe::Toy { name, .. } => name,
        }
    }

    /// Seconds between rows, if set (`None`: at the output steps).
    pub fn interval(&self) -> Option<f64> {
        match self {
            Probe::Pressure { interval, .. }
            | Probe::VelocityLine { interval, .. }
            | Probe::Gauge { interval, .. }
            | Probe::Front { interval, .. }
            | Probe::Force { interval, .. }
            | Probe::Hole { interval, .. } => *interval,
            #[cfg(test)]
            Probe::Toy { interval, .. } => *interval,
        }
    }

    /// Averaging window (s; 0 = none).
    pub fn window(&self) -> f64 {
        match self {
            Probe::Pressure { window, .. } | Probe::Force { window, .. } => *window,
            Probe::VelocityLine { .. } | Probe::Gauge { .. } | Probe::Front { .. } | Probe::Hole { .. } => {
                0.0
            }
            #[cfg(test)]
            Probe::Toy { .. } => 0.0,
        }
    }

    /// Column names of the probe's file after `t`, in a `dim`-dimensional scene: the one
    /// statement of a kind's columns, read by the file's header (`crate::probes`) and by the
    /// volume estimate (`crate::output::volume`).
    pub fn columns(&self, dim: usize) -> Vec<String> {
        let comps = ["vx", "vy", "vz"];
        match self {
            Probe::Pressure { .. } => vec!["p".into()],
            Probe::VelocityLine { points, .. } => (0..*points)
                .flat_map(|k| comps[..dim].iter().map(move |c| format!("s{k}_{c}")))
                .collect(),
            Probe::Gauge { .. } => vec!["eta".into()],
            Probe::Front { .. } => vec!["front".into()],
            #[cfg(test)]
            Probe::Toy { .. } => vec!["mass".into()],
            Probe::Hole { .. } => HOLE_COLUMNS.iter().map(|c| c.to_string()).collect(),
            Probe::Force { .. } => {
                let f = ["fx", "fy", "fz"][..dim].iter().map(|s| s.to_string());
                let m: &[&str] = if dim == 3 { &["mx", "my", "mz"] } else { &["mz"] };
                f.chain(m.iter().map(|s| s.to_string())).collect()
            }
        }
    }

    /// A pressure probe's load rules for `summary.json` (`crate::probes::loads`): the box
    /// filter's width (s) and the impulse's span (s, if any); `None` for every other kind.
    pub fn load_rules(&self) -> Option<(f64, Option<f64>)> {
        match self {
            Probe::Pressure {
                filter, impulse_span, ..
            } => Some((filter.unwrap_or(DEFAULT_LOAD_FILTER_S), *impulse_span)),
            Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// True for a pressure probe whose rows are not its every-step samples (it averages over a
    /// trailing `window`, or writes rows less often than every step): its samples of every
    /// step then go to `probes/<name>.raw.csv` as well, and `summary.json`'s loads are read
    /// from them (`crate::probes::loads_file`), so the raw maximum, the box filter and the
    /// impulse never see the trailing window or a row interval.
    pub fn raw_series(&self) -> bool {
        matches!(self, Probe::Pressure { window, interval, .. } if *window > 0.0 || *interval != Some(0.0))
    }

    /// The moving wall a pressure probe rides on (its key `body`), if any.
    pub fn rides_on(&self) -> Option<&str> {
        match self {
            Probe::Pressure { body, .. } => body.as_deref(),
            _ => None,
        }
    }

    /// This probe with its point moved by `shift` (m): a pressure sensor carried by its wall
    /// ([`Probe::rides_on`]); every other probe unchanged.
    pub fn moved(&self, shift: &[f64]) -> Probe {
        let mut p = self.clone();
        if let Probe::Pressure { point, .. } = &mut p {
            point.iter_mut().zip(shift).for_each(|(x, s)| *x += s);
        }
        p
    }

    /// A pressure probe's point (m; the centre of its face); `None` for every other kind.
    pub fn sensor_point(&self) -> Option<&[f64]> {
        match self {
            Probe::Pressure { point, .. } => Some(point),
            Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// A velocity line's number of sample points (`None` for every other kind): bounded by
    /// `limits::MAX_PROBE_POINTS` before anything is allocated.
    pub fn line_points(&self) -> Option<usize> {
        match self {
            Probe::VelocityLine { points, .. } => Some(*points),
            Probe::Pressure { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// A pressure transducer's sensing face, (diameter (m), normal), when it has one
    /// (diameter > 0); `None` for a point sensor and every other kind.
    pub fn face(&self) -> Option<(f64, Option<&[f64]>)> {
        match self {
            Probe::Pressure { diameter, normal, .. } if *diameter != 0.0 => {
                Some((*diameter, normal.as_deref()))
            }
            Probe::Pressure { .. }
            | Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// The `[[wall]]` a force probe measures (`None` for every other kind).
    pub fn force_body(&self) -> Option<&str> {
        match self {
            Probe::Force { body, .. } => Some(body),
            Probe::Pressure { .. }
            | Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// A hole probe's (plate, projectile) `[[solid]]` bodies (`None` for every other kind).
    pub fn hole_bodies(&self) -> Option<(&str, &str)> {
        match self {
            Probe::Hole {
                plate, projectile, ..
            } => Some((plate, projectile)),
            Probe::Pressure { .. }
            | Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// A wave gauge's station (m; the last coordinate is ignored), `None` for every other
    /// kind: the gauges a reference's wave compares with.
    pub fn gauge_point(&self) -> Option<&[f64]> {
        match self {
            Probe::Gauge { point, .. } => Some(point),
            Probe::Pressure { .. }
            | Probe::VelocityLine { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. } => None,
            #[cfg(test)]
            Probe::Toy { .. } => None,
        }
    }

    /// The header line of the probe's file: `t` then [`Probe::columns`].
    pub fn header(&self, dim: usize) -> String {
        format!("t,{}", self.columns(dim).join(","))
    }
}

/// Column names of a hole probe after `t` (`crate::probes::hole::Hole::COLUMNS`).
pub const HOLE_COLUMNS: [&str; 10] = [
    "perforated",
    "major",
    "minor",
    "angle",
    "area",
    "centre_u",
    "centre_v",
    "debris",
    "debris_length",
    "debris_width",
];

/// The keys of probe `k` that depend on its kind.
fn validate_probe_kind(
    k: &str,
    probe: &mut Probe,
    d: usize,
    domain: &Domain,
    t: &ProbeTargets,
) -> Result<()> {
    match probe {
        Probe::Pressure {
            point,
            diameter,
            normal,
            filter,
            impulse_span,
            body,
            ..
        } => {
            check_pressure(k, (point, *diameter, normal), d, domain)?;
            if let Some(b) = body {
                check_rider(k, b, t)?;
            }
            check_load_rules(k, *filter, *impulse_span)
        }
        Probe::Gauge { point, .. } => {
            check_vec(point, d, &format!("{k}.point"), false)?;
            point_in_domain(point, &format!("{k}.point"), domain)
        }
        Probe::Hole {
            plate, projectile, ..
        } => check_hole(k, plate, projectile, t),
        Probe::VelocityLine { from, to, points, .. } => {
            check_vec(from, d, &format!("{k}.from"), false)?;
            check_vec(to, d, &format!("{k}.to"), false)?;
            point_in_domain(from, &format!("{k}.from"), domain)?;
            point_in_domain(to, &format!("{k}.to"), domain)?;
            if *points < 2 {
                return err(format!("{k}.points"), "needs at least 2 points");
            }
            crate::limits::count(
                &format!("{k}.points"),
                *points as u64,
                crate::limits::MAX_PROBE_POINTS,
            )
        }
        Probe::Front { axis, link, .. } => {
            if *axis >= d {
                return err(format!("{k}.axis"), format!("must be below dimension {d}"));
            }
            if !(*link >= 1.0 && link.is_finite()) {
                return err(
                    format!("{k}.link"),
                    format!("must be ≥ 1 (in units of dx; 1.5 is typical), got {link}"),
                );
            }
            Ok(())
        }
        Probe::Force { body, about, .. } => check_force(k, body, about, d, t),
        #[cfg(test)]
        Probe::Toy { .. } => Ok(()),
    }
}

/// A pressure transducer: its point in the domain, a diameter ≥ 0, and a non-zero normal when
/// it has a sensing face.
fn check_pressure(
    k: &str,
    (point, diameter, normal): (&mut Vec<f64>, f64, &mut Option<Vec<f64>>),
    d: usize,
    domain: &Domain,
) -> Result<()> {
    check_vec(point, d, &format!("{k}.point"), false)?;
    point_in_domain(point, &format!("{k}.point"), domain)?;
    if !(diameter >= 0.0 && diameter.is_finite()) {
        return err(format!("{k}.diameter"), format!("must be ≥ 0 m, got {diameter}"));
    }
    match normal {
        Some(n) => {
            check_vec(n, d, &format!("{k}.normal"), false)?;
            if n.iter().all(|c| *c == 0.0) {
                return err(
                    format!("{k}.normal"),
                    "must not be zero: the wall's normal, e.g. [-1.0, 0.0]",
                );
            }
        }
        None if diameter > 0.0 && d > 1 => {
            return err(
                format!("{k}.normal"),
                "a sensing face with a diameter needs the wall's normal, e.g. normal = [-1.0, 0.0]",
            );
        }
        None => {}
    }
    Ok(())
}

/// Warnings about pressure sensors that read the discretisation more than the flow: a face
/// narrower than the fluid's spacing there (it averages less than one particle's width), and a
/// sensor within one kernel support of a corner where two closed faces of a wall meet (its
/// reading includes the corner's error; docs/pressure.md §2). Spacing and support are those
/// at the sensor ([`Resolution::at`]): a sensor inside a `[[refine]]` region is judged by the
/// region's finer particles, not the scene's.
pub(super) fn sensor_warnings(s: &Scene) -> Vec<String> {
    let d = s.dimension;
    let mut out = Vec::new();
    for (k, probe) in s.probes.iter().enumerate() {
        let Some(x) = probe.sensor_point() else {
            continue;
        };
        let name = probe.name();
        let here = Resolution::at(s, x);
        if let Some((diameter, _)) = probe.face().filter(|f| f.0 < here.dx) {
            out.push(format!(
                "probe[{k}] `{name}`: its face ({:.3} mm) is narrower than {} ({:.3} mm), so it \
                 averages less than one particle's width; widen `diameter` or refine",
                1e3 * diameter,
                here.spacing_name(),
                1e3 * here.dx
            ));
        }
        if let Some((wall, dist)) = nearest_corner(s, x, d).filter(|c| c.1 < here.support) {
            out.push(format!(
                "probe[{k}] `{name}`: the sensor lies {:.3} mm from a corner of wall `{wall}`, \
                 within one kernel support ({:.3} mm{}): its reading includes the corner's error \
                 (docs/pressure.md §2); move it or refine",
                1e3 * dist,
                1e3 * here.support,
                match here.region {
                    Some((r, _)) => format!(" in refine[{r}]"),
                    None => String::new(),
                }
            ));
        }
    }
    out
}

/// The fluid's spacing and kernel support at a point.
struct Resolution {
    /// Particle spacing (m).
    dx: f64,
    /// Kernel support radius κh (m).
    support: f64,
    /// The refinement region that sets them (its index and level), if any.
    region: Option<(usize, u32)>,
}

impl Resolution {
    /// At `x` (m): those of the finest `[[refine]]` region that holds `x` and refines some
    /// fluid (spacing dx/2^ℓ; the support follows the smoothing length its particles take
    /// there, [`super::refine::Refine::smoothing_length`]), else the scene's.
    fn at(s: &Scene, x: &[f64]) -> Resolution {
        let disc = &s.discretisation;
        let finest = (s.refine.iter().enumerate())
            .filter(|(_, r)| r.contains(x) && s.fluids.iter().any(|f| r.applies_to(&f.name)))
            .max_by_key(|(i, r)| (r.level, std::cmp::Reverse(*i)));
        let Some((i, r)) = finest else {
            return Resolution {
                dx: disc.dx,
                support: disc.support(),
                region: None,
            };
        };
        let h = disc.h_over_dx * disc.dx;
        let fine = f64::powi(2.0, r.level as i32);
        let local_h = r.smoothing_length(x, &super::refine::Bounds::of(s), h, h / fine);
        Resolution {
            dx: disc.dx / fine,
            support: disc.support() * local_h / h,
            region: Some((i, r.level)),
        }
    }

    /// How a message names the spacing: `dx`, or the region's level spacing.
    fn spacing_name(&self) -> String {
        match self.region {
            None => "dx".to_string(),
            Some((r, level)) => format!("the spacing of refine[{r}] (dx/2^{level})"),
        }
    }
}

/// The nearest corner to `x` (m) of any wall with particles or images: where two closed faces
/// of its box meet (an edge in 3D), measured in the plane of their two axes, for a point
/// within the box's extent along the other axes. The wall's name and the distance (m).
fn nearest_corner<'s>(s: &'s Scene, x: &[f64], d: usize) -> Option<(&'s str, f64)> {
    let mut best: Option<(&str, f64)> = None;
    for w in &s.walls {
        let closed = |a: usize, up: bool| !w.open.iter().any(|o| face(o, d) == Some((a, up)));
        for a in 0..d {
            for b in a + 1..d {
                let others = (0..d)
                    .filter(|&c| c != a && c != b)
                    .all(|c| x[c] >= w.min[c] && x[c] <= w.max[c]);
                if !others {
                    continue;
                }
                for (ua, ub) in [(false, false), (false, true), (true, false), (true, true)] {
                    if !(closed(a, ua) && closed(b, ub)) {
                        continue;
                    }
                    let ca = if ua { w.max[a] } else { w.min[a] };
                    let cb = if ub { w.max[b] } else { w.min[b] };
                    let dist = (x[a] - ca).hypot(x[b] - cb);
                    if best.is_none_or(|(_, bd)| dist < bd) {
                        best = Some((w.name.as_str(), dist));
                    }
                }
            }
        }
    }
    best
}

/// A pressure probe's load rules: a filter width ≥ 0 s and an impulse span > 0 s, both finite.
fn check_load_rules(k: &str, filter: Option<f64>, span: Option<f64>) -> Result<()> {
    if let Some(f) = filter {
        if !(f >= 0.0 && f.is_finite()) {
            return err(
                format!("{k}.filter"),
                format!("must be a width ≥ 0 s (0 = no filter), got {f}; e.g. filter = 0.002"),
            );
        }
    }
    if let Some(w) = span {
        if !(w > 0.0 && w.is_finite()) {
            return err(
                format!("{k}.impulse_span"),
                format!("must be a span > 0 s, got {w}; e.g. impulse_span = 0.035"),
            );
        }
    }
    Ok(())
}

/// A hole probe: its plate and projectile are solid bodies, and the projectile moves (its
/// velocity is the impact direction).
fn check_hole(k: &str, plate: &str, projectile: &str, t: &ProbeTargets) -> Result<()> {
    for (key, name) in [("plate", plate), ("projectile", projectile)] {
        if !t.solids.contains_key(name) {
            return err(
                format!("{k}.{key}"),
                format!(
                    "no [[solid]] body named `{name}`; solids: {}",
                    t.solid_names.shown()
                ),
            );
        }
    }
    let pr = t.solids.get(projectile);
    if pr.is_some_and(|b| b.velocity.iter().all(|c| *c == 0.0)) {
        return err(
            format!("{k}.projectile"),
            format!("`{projectile}` does not move: its velocity is the impact direction"),
        );
    }
    Ok(())
}

/// The wall a probe's `{k}.body` names, or an input error listing the walls.
fn named_wall<'t>(k: &str, body: &str, t: &ProbeTargets<'t>) -> Result<&'t WallBody> {
    t.walls.get(body).copied().ok_or_else(|| {
        crate::error::Error::input(
            format!("{k}.body"),
            format!(
                "no [[wall]] is named `{body}`; the walls are {}",
                t.wall_names.shown()
            ),
        )
    })
}

/// A pressure sensor's `body`: a wall of the scene that moves (it has a `motion`).
fn check_rider(k: &str, body: &str, t: &ProbeTargets) -> Result<()> {
    if named_wall(k, body, t)?.motion.is_none() {
        return err(
            format!("{k}.body"),
            format!(
                "wall `{body}` has no motion, so a sensor on it stays where it is: leave `body` out, \
                 or give the wall a motion, e.g. motion = {{ law = \"constant_velocity\", velocity = [0.0, -1.0] }}"
            ),
        );
    }
    Ok(())
}

/// A force probe: its body is a wall with particles (not a mirror), its moment point a
/// vector of the dimension.
fn check_force(k: &str, body: &str, about: &mut Option<Vec<f64>>, d: usize, t: &ProbeTargets) -> Result<()> {
    let w = named_wall(k, body, t)?;
    if w.method.makes_images() {
        return err(
            format!("{k}.body"),
            format!("wall `{body}` is a mirror, which has no particles to take a force on; use a dummy or repulsive wall"),
        );
    }
    if let Some(a) = about {
        check_vec(a, d, &format!("{k}.about"), false)?;
    }
    Ok(())
}

pub(super) fn validate_probes(s: &mut Scene) -> Result<()> {
    let t = ProbeTargets {
        walls: s.walls.iter().map(|w| (w.name.as_str(), w)).collect(),
        solids: s.solids.iter().map(|b| (b.name.as_str(), b)).collect(),
        wall_names: Names::new(s.walls.iter().map(|w| w.name.as_str())),
        solid_names: Names::new(s.solids.iter().map(|b| b.name.as_str())),
    };
    let mut seen = std::collections::HashSet::new();
    for (i, probe) in s.probes.iter_mut().enumerate() {
        let k = format!("probe[{i}]");
        let name = probe.name().to_string();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return err(
                format!("{k}.name"),
                format!("`{name}` must be non-empty letters, digits, _ or -"),
            );
        }
        if !seen.insert(name.clone()) {
            return err(format!("{k}.name"), format!("probe `{name}` is defined twice"));
        }
        if let Some(iv) = probe.interval() {
            if !(iv >= 0.0 && iv.is_finite()) {
                return err(
                    format!("{k}.interval"),
                    format!("must be ≥ 0 s (0 = every step; leave it out for the output interval), got {iv}"),
                );
            }
        }
        let window = probe.window();
        if !(window >= 0.0 && window.is_finite()) {
            return err(
                format!("{k}.window"),
                format!("must be ≥ 0 s (0 = no time average), got {window}"),
            );
        }
        validate_probe_kind(&k, probe, s.dimension, &s.domain, &t)?;
    }
    Ok(())
}

/// The bodies probes refer to by name, looked up in O(1) (a scene may hold thousands of
/// probes and bodies).
struct ProbeTargets<'s> {
    walls: std::collections::HashMap<&'s str, &'s WallBody>,
    solids: std::collections::HashMap<&'s str, &'s FluidBody>,
    wall_names: Names,
    solid_names: Names,
}

/// One probe of every kind in a `d`-dimensional scene, for tests that must cover them all
/// (the volume estimate's columns): a new kind is added here, where its variant is.
#[cfg(test)]
pub(crate) fn one_of_each(d: usize) -> Vec<Probe> {
    let v = |d: usize| vec![0.5; d];
    let all = vec![
        Probe::Pressure {
            name: "p".into(),
            point: v(d),
            diameter: 0.0,
            normal: None,
            window: 0.0,
            interval: None,
            filter: None,
            impulse_span: None,
            body: None,
        },
        Probe::VelocityLine {
            name: "v".into(),
            from: v(d),
            to: vec![0.6; d],
            points: 7,
            interval: None,
        },
        Probe::Gauge {
            name: "g".into(),
            point: v(d),
            interval: None,
        },
        Probe::Front {
            name: "f".into(),
            axis: 0,
            direction: Default::default(),
            link: 1.5,
            interval: None,
        },
        Probe::Force {
            name: "F".into(),
            body: "w".into(),
            about: None,
            window: 0.0,
            interval: None,
        },
        Probe::Hole {
            name: "h".into(),
            plate: "a".into(),
            projectile: "b".into(),
            interval: None,
        },
        Probe::Toy {
            name: "m".into(),
            interval: None,
        },
    ];
    // every kind is listed above: this match stops compiling when one is added
    for p in &all {
        match p {
            Probe::Pressure { .. }
            | Probe::VelocityLine { .. }
            | Probe::Gauge { .. }
            | Probe::Front { .. }
            | Probe::Force { .. }
            | Probe::Hole { .. }
            | Probe::Toy { .. } => {}
        }
    }
    all
}
