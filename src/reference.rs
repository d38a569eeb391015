//! Analytic and tabulated references a scene can declare; the named relative errors (as
//! fractions: 0.004 means 0.4 %) go to `summary.json` under `errors`.

pub mod wall_pressure;

use crate::scene::Reference;
use crate::sim::View;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Koshizuka & Oka (1996) experimental surge front, Z = z/L against T = t sqrt(2g/L)
/// (`inputs/reference/dambreak2d_koshizuka_oka1996_front.csv`, with its sources).
const KO_FRONT: &str = include_str!("../inputs/reference/dambreak2d_koshizuka_oka1996_front.csv");

/// Ghia, Ghia & Shin (1982) Table I, u on x = 0.5 (`inputs/reference/`, with its sources).
const GHIA_U: &str = include_str!("../inputs/reference/ghia1982_cavity_u_vertical_centreline.csv");
/// Table II, v on y = 0.5.
const GHIA_V: &str = include_str!("../inputs/reference/ghia1982_cavity_v_horizontal_centreline.csv");

/// Steady state of the cavity: kinetic energy changing by less than this fraction per unit
/// time L/U (the slope of a least-squares line through the output steps of the last
/// [`STEADY_WINDOW`], over their mean: SPH's particle noise, ±1 % between output steps, would
/// swamp a two-point difference).
pub const STEADY_RATE: f64 = 1e-3;

/// Length of the window the kinetic energy's trend is fitted over, in units of L/U.
pub const STEADY_WINDOW: f64 = 5.0;

/// Ghia's interior points (the wall points, which the boundary condition fixes, left out) for
/// `re`: (coordinate along the line, velocity / U), from `table` (u or v).
pub fn ghia(table: &str, re: u32) -> Vec<(f64, f64)> {
    let mut lines = table.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let Some(col) = head.iter().position(|c| c.ends_with(&format!("_Re{re}"))) else {
        return Vec::new();
    };
    lines
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Some((f.get(1)?.parse::<f64>().ok()?, f.get(col)?.parse::<f64>().ok()?))
        })
        .filter(|&(c, _)| c > 0.0 && c < 1.0)
        .collect()
}

/// Points of a centreline profile: (coordinate / L, velocity / U).
pub type Profile = Vec<(f64, f64)>;

/// The cavity's reference points for `re`: u on x = 1/2 and v on y = 1/2 as (coordinate,
/// velocity / U). Re = 100, 400, 1000: Ghia et al.'s interior points; Re = 1: the
/// finite-difference Stokes solution ([`crate::stokes_cavity`]) at the same coordinates.
pub fn cavity_reference(re: u32) -> (Profile, Profile) {
    if re == 1 {
        let s = crate::stokes_cavity::shared();
        let u = ghia(GHIA_U, 100)
            .iter()
            .map(|&(y, _)| (y, s.u_centre(y)))
            .collect();
        let v = ghia(GHIA_V, 100)
            .iter()
            .map(|&(x, _)| (x, s.v_centre(x)))
            .collect();
        (u, v)
    } else {
        (ghia(GHIA_U, re), ghia(GHIA_V, re))
    }
}

/// Transient plane Poiseuille flow (Morris et al. 1997; docs/analytic.md §1a), u(y, t) (m/s) for
/// body force `f` (m/s²), kinematic viscosity `nu` (m²/s), plates at y = 0 and y = `l`.
pub fn poiseuille(y: f64, t: f64, f: f64, nu: f64, l: f64) -> f64 {
    let mut u = f / (2.0 * nu) * y * (l - y);
    for n in 0..400 {
        let k = (2 * n + 1) as f64;
        let term = 4.0 * f * l * l / (nu * PI.powi(3) * k.powi(3))
            * (k * PI * y / l).sin()
            * (-k * k * PI * PI * nu * t / (l * l)).exp();
        u -= term;
        if term.abs() < 1e-20 * f * l * l / nu {
            break;
        }
    }
    u
}

/// Impulsively started Couette flow (docs/analytic.md §1b), u(y, t) (m/s), upper plate speed `v0`.
pub fn couette(y: f64, t: f64, v0: f64, nu: f64, l: f64) -> f64 {
    let mut u = v0 * y / l;
    for n in 1..4000 {
        let nf = n as f64;
        let decay = (-nu * nf * nf * PI * PI * t / (l * l)).exp();
        if decay < 1e-18 {
            break;
        }
        let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
        u += 2.0 * v0 * sign / (nf * PI) * (nf * PI * y / l).sin() * decay;
    }
    u
}

/// Maximum run-up R (m) of a solitary wave of height `a` (m) on depth `h` (m) at a vertical
/// wall: the head-on collision of two equal waves, to third order in α = A/h (Su & Mirie
/// 1980, J. Fluid Mech. 98, 509, as quoted by Cooker, Weidman & Bale 1997 and Chambarel,
/// Kharif & Touboul 2009): R/h = 2α + α²/2 + 3α³/4.
pub fn su_mirie_runup(a: f64, h: f64) -> f64 {
    let al = a / h;
    h * (2.0 * al + 0.5 * al * al + 0.75 * al * al * al)
}

/// Tracks a scene's reference during a run (its state goes into checkpoints).
#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Tracker {
    /// Named errors measured so far.
    pub errors: BTreeMap<String, f64>,
    /// Named measured values beside the errors (with their units in the name), for
    /// `summary.json`'s `measured`.
    #[serde(default)]
    pub measured: BTreeMap<String, f64>,
    next_time: usize,
    front: Vec<(f64, f64)>,
    /// The cavity's output steps within the last [`STEADY_WINDOW`]: (t, kinetic energy of the
    /// fluid).
    #[serde(default)]
    ke: Vec<(f64, f64)>,
    /// The wall-pressure comparisons by probe, kept for `summary.json`'s `pressure_loads`
    /// (computed once, at the end).
    #[serde(skip)]
    pub pressure: BTreeMap<String, wall_pressure::Comparison>,
}

impl Tracker {
    /// True if a measurement of the reference is due at time `t` (the same answer on every
    /// rank, so all ranks gather the state together).
    pub fn due(&self, scene: &crate::scene::Scene, t: f64) -> bool {
        match &scene.reference {
            Some(Reference::Poiseuille { times, .. })
            | Some(Reference::Couette { times, .. })
            | Some(Reference::TaylorGreen { times, .. }) => {
                self.next_time < times.len() && t >= times[self.next_time] * (1.0 - 1e-12)
            }
            _ => false,
        }
    }

    /// Advance past the measurements due at `t` without measuring (ranks other than 0).
    pub fn skip(&mut self, scene: &crate::scene::Scene, t: f64) {
        while self.due(scene, t) {
            self.next_time += 1;
        }
    }

    /// Called after every step: measures the errors due at this time.
    pub fn after_step<const D: usize>(&mut self, sim: &View<D>) {
        let Some(r) = &sim.scene.reference else { return };
        match r {
            Reference::Poiseuille { gap, times } | Reference::Couette { gap, times, .. } => {
                while self.next_time < times.len() && sim.t >= times[self.next_time] * (1.0 - 1e-12) {
                    let label = times[self.next_time];
                    let e = channel_error(sim, r, *gap);
                    self.errors.insert(format!("velocity_linf_t{label}"), e);
                    self.next_time += 1;
                }
            }
            Reference::TaylorGreen { speed, length, times } => {
                while self.next_time < times.len() && sim.t >= times[self.next_time] * (1.0 - 1e-12) {
                    let label = times[self.next_time];
                    let (e, dmin, cv) = taylor_green_error(sim, *speed, *length);
                    self.errors.insert(format!("velocity_linf_t{label}"), e);
                    self.measured
                        .insert(format!("min_pair_distance_over_dx_t{label}"), dmin);
                    self.measured.insert(format!("nearest_distance_cv_t{label}"), cv);
                    self.next_time += 1;
                }
            }
            Reference::DamBreakFront { .. }
            | Reference::SolitaryWave { .. }
            | Reference::WallPressure { .. }
            | Reference::Hydrostatic { .. }
            | Reference::Hole { .. }
            | Reference::Cavity { .. } => {}
        }
    }

    /// True if `scene`'s reference measures the gathered fluid at every output step
    /// ([`Tracker::at_output`] is given the fluid particles alone).
    pub fn measures_at_output(scene: &crate::scene::Scene) -> bool {
        matches!(
            scene.reference,
            Some(Reference::DamBreakFront { .. }) | Some(Reference::Cavity { .. })
        )
    }

    /// Called at every output step (front history for the dam break): the leading particle of
    /// the main body along +x (the front probe's definition, detached spray ignored) plus dx/2,
    /// the edge of its cell.
    pub fn at_output<const D: usize>(&mut self, sim: &View<D>) {
        if let Some(Reference::Cavity { .. }) = &sim.scene.reference {
            self.cavity(sim);
        }
        if let Some(Reference::DamBreakFront { .. }) = &sim.scene.reference {
            let dx = sim.scene.discretisation.dx;
            let front = crate::probes::sensors::front(sim, 0, crate::scene::Direction::Plus, 1.5 * dx);
            self.front.push((sim.t, front + 0.5 * dx));
        }
    }

    /// Called once at the end of the run.
    pub fn finish<const D: usize>(&mut self, sim: &View<D>) {
        match &sim.scene.reference {
            Some(Reference::Hole { major, minor, .. }) => {
                // the hole of the final state (the settled history is the probe's, in
                // summary.json's `hole`)
                let probe = sim.scene.probes.iter().find_map(|p| p.hole_bodies());
                if let Some((plate, projectile)) = probe {
                    let setup = crate::probes::hole::HoleSetup::<D>::of(sim.scene, plate, projectile);
                    let ids: Vec<usize> = (0..sim.p.n_owned).collect();
                    let h = crate::probes::hole::measure(&sim.p, &ids, &setup);
                    self.errors
                        .insert("hole_major".into(), (h.major / major - 1.0).abs());
                    self.errors
                        .insert("hole_minor".into(), (h.minor / minor - 1.0).abs());
                }
            }
            Some(Reference::Hydrostatic { surface, bottom }) => {
                let g = sim.model.g.norm();
                // the fluid's own ρ0 (a wall's or another material listed first would not do)
                let rho0_of = |i: usize| sim.model.materials[sim.p.mat[i] as usize].rho0();
                let h = surface - bottom;
                let mid = bottom + 0.5 * h;
                let mut ep: f64 = 0.0;
                let mut vmax: f64 = 0.0;
                let mut inside = 0usize;
                let n_fluid = (0..sim.p.n_owned).filter(|&i| sim.p.kind[i].is_fluid()).count();
                for i in 0..sim.p.n_owned {
                    if !sim.p.kind[i].is_fluid() {
                        continue;
                    }
                    let y = sim.p.x[i][D - 1];
                    if y < mid {
                        let rho0 = rho0_of(i);
                        let exact = rho0 * g * (surface - y);
                        ep = ep.max((sim.p.p[i] - exact).abs() / (rho0 * g * h));
                    }
                    vmax = vmax.max(sim.p.v[i].norm());
                    if !inside_fluid_region(sim, i) {
                        inside += 1;
                    }
                }
                self.errors.insert("pressure_linf_below_mid_depth".into(), ep);
                self.errors
                    .insert("max_speed_over_sqrt_gh".into(), vmax / (g * h).sqrt());
                self.errors.insert(
                    "fluid_in_walls_fraction".into(),
                    inside as f64 / n_fluid.max(1) as f64,
                );
            }
            Some(Reference::DamBreakFront { column_width, origin }) => {
                let g = sim.model.g.norm();
                let l = *column_width;
                let tscale = (2.0 * g / l).sqrt();
                let mut sum = 0.0;
                let mut n = 0;
                for line in KO_FRONT.lines().filter(|l| l.starts_with("experiment,")) {
                    let f: Vec<f64> = line.split(',').skip(1).filter_map(|s| s.parse().ok()).collect();
                    let (tt, z) = (f[0], f[1]);
                    let t = tt / tscale;
                    if t <= 0.0 || t > sim.t || self.front.len() < 2 {
                        continue;
                    }
                    if let Some(sim_front) = interpolate(&self.front, t) {
                        sum += ((sim_front - origin) / l - z).abs() / z;
                        n += 1;
                    }
                }
                if n > 0 {
                    self.errors
                        .insert("front_mean_rel_vs_koshizuka_oka".into(), sum / n as f64);
                }
            }
            _ => {}
        }
    }
}

impl Tracker {
    /// The wall-pressure reference: each named probe against the experiment, kept and as
    /// errors.
    fn wall_pressure(
        &mut self,
        scene: &crate::scene::Scene,
        experiment: crate::scene::PressureExperiment,
        sensors: &[String],
        dir: &std::path::Path,
    ) {
        self.pressure = wall_pressure::compare(scene, experiment, sensors, dir);
        for (name, c) in &self.pressure {
            self.errors.insert(format!("{name}_peak"), c.peak_error.abs());
            if let Some(e) = c.impulse_error {
                self.errors.insert(format!("{name}_impulse"), e.abs());
            }
        }
    }

    /// References measured on probe series, read back from the run's probe files in `dir`
    /// on rank 0 at the end (the whole history, across restarts). The solitary wave: the
    /// crest above the gauge's first reading (still water) against A; the arrival gauge's
    /// crest time against [`crate::boundary::motion::Goring::crest_time`] at its distance
    /// from the paddle's rest face; the run-up gauge's rise against [`su_mirie_runup`].
    pub fn from_probe_files(&mut self, scene: &crate::scene::Scene, dir: &std::path::Path) {
        if let Some(Reference::WallPressure { experiment, sensors }) = &scene.reference {
            self.wall_pressure(scene, *experiment, sensors, dir);
            return;
        }
        let Some(Reference::SolitaryWave {
            crest_gauge,
            arrival_gauge,
            runup_gauge,
        }) = &scene.reference
        else {
            return;
        };
        let Some((wall, a, h, e)) = scene.walls.iter().find_map(|w| match &w.motion {
            Some(crate::scene::Motion::Solitary {
                amplitude,
                depth,
                direction,
            }) => Some((w, *amplitude, *depth, direction.clone())),
            _ => None,
        }) else {
            return;
        };
        let g = scene.physics.body_force.iter().map(|x| x * x).sum::<f64>().sqrt();
        let law = crate::boundary::motion::Goring::new(a, h, g);
        // the paddle's rest face: its box's furthest extent along the push direction
        let face: f64 = (0..e.len())
            .map(|k| (e[k] * wall.min[k]).max(e[k] * wall.max[k]))
            .sum();
        // (still-water reading, crest reading, crest time, last time) of a gauge's series
        let series = |name: &str| -> Option<(f64, f64, f64, f64)> {
            let text = std::fs::read_to_string(dir.join(format!("{name}.csv"))).ok()?;
            let rows: Vec<(f64, f64)> = text
                .lines()
                .skip(1)
                .filter_map(|l| {
                    let (t, z) = l.split_once(',')?;
                    Some((t.parse().ok()?, z.parse().ok()?))
                })
                .collect();
            let z0 = rows.first()?.1;
            let top = rows
                .iter()
                .copied()
                .fold((0.0, f64::MIN), |m, r| if r.1 > m.1 { r } else { m });
            Some((z0, top.1, top.0, rows.last()?.0))
        };
        let distance = |name: &str| -> f64 {
            scene
                .probes
                .iter()
                .filter(|p| p.name() == name)
                .find_map(|p| p.gauge_point())
                .map(|point| (0..e.len()).map(|k| e[k] * point[k]).sum::<f64>() - face)
                .unwrap_or(f64::NAN)
        };
        // a gauge's crest, once the wave has passed it: the run reaches the crest's time by
        // Goring's celerity and the series' highest reading is not its last (a run stopped
        // before the wave arrived, or while it rises, measures nothing there, and says so)
        let crest = |name: &str| -> Option<(f64, f64, f64)> {
            let (z0, z1, t, last) = series(name)?;
            let due = law.crest_time(distance(name));
            if last < due || t >= last {
                eprintln!(
                    "hsph: warning: the solitary wave has not passed gauge `{name}` by the end of the \
                     run (t = {last:.4} s; its crest is due at about {due:.4} s): its error is not measured"
                );
                return None;
            }
            Some((z0, z1, t))
        };
        self.measured.insert("wave_height_m".into(), a);
        self.measured.insert("celerity_m_per_s".into(), law.c);
        let at_crest_gauge = crest(crest_gauge);
        if let Some((z0, z1, _)) = at_crest_gauge {
            self.measured.insert("crest_height_m".into(), z1 - z0);
            self.errors
                .insert("solitary_crest".into(), ((z1 - z0) / a - 1.0).abs());
        }
        if let Some((_, _, t)) = crest(arrival_gauge) {
            let t_ref = law.crest_time(distance(arrival_gauge));
            self.measured.insert("arrival_time_s".into(), t);
            self.measured.insert("arrival_time_reference_s".into(), t_ref);
            self.errors
                .insert("solitary_arrival".into(), (t / t_ref - 1.0).abs());
            if let Some((_, _, t0)) = at_crest_gauge {
                let dx = distance(arrival_gauge) - distance(crest_gauge);
                self.measured
                    .insert("celerity_between_gauges_m_per_s".into(), dx / (t - t0));
            }
        }
        if let Some((z0, z1, t)) = crest(runup_gauge) {
            let r_ref = su_mirie_runup(a, h);
            self.measured.insert("runup_m".into(), z1 - z0);
            self.measured.insert("runup_time_s".into(), t);
            self.measured.insert("runup_su_mirie_m".into(), r_ref);
            self.errors
                .insert("solitary_runup".into(), ((z1 - z0) / r_ref - 1.0).abs());
        }
    }

    /// The cavity at an output step: u on the vertical and v on the horizontal centreline at
    /// Ghia's interior points (Shepard interpolation of the fluid, W-weighted), each error
    /// max |SPH − Ghia| / U; the kinetic energy's relative change per unit time L/U since the
    /// last [`STEADY_WINDOW`] and whether it is below [`STEADY_RATE`].
    fn cavity<const D: usize>(&mut self, sim: &View<D>) {
        let Some(Reference::Cavity {
            re,
            lid_speed,
            size,
            origin,
        }) = &sim.scene.reference
        else {
            return;
        };
        let (l, u) = (*size, *lid_speed);
        let p = &sim.p;
        let fluid: Vec<usize> = (0..p.n_owned).filter(|&i| p.kind[i].is_fluid()).collect();
        // velocity component `c` at the point (x, y) (m), Shepard-weighted
        let at = |x: f64, y: f64, c: usize| -> f64 {
            let (mut num, mut den) = (0.0, 0.0);
            for &i in &fluid {
                let (dx, dy) = (p.x[i][0] - x, p.x[i][1] - y);
                let r = (dx * dx + dy * dy).sqrt();
                if r < sim.model.kernel.support {
                    let w = sim.model.pair_kernel(p, i, i).w(r) * p.mass[i] / p.rho[i];
                    num += w * p.v[i][c];
                    den += w;
                }
            }
            if den > 0.0 {
                num / den
            } else {
                f64::NAN
            }
        };
        let (x0, y0) = (origin[0], origin[1]);
        let (ur, vr) = cavity_reference(*re);
        let eu = ur
            .iter()
            .map(|&(y, g)| (at(x0 + 0.5 * l, y0 + y * l, 0) / u - g).abs())
            .fold(0.0, f64::max);
        let ev = vr
            .iter()
            .map(|&(x, g)| (at(x0 + x * l, y0 + 0.5 * l, 1) / u - g).abs())
            .fold(0.0, f64::max);
        self.errors.insert("cavity_u_linf".into(), eu);
        self.errors.insert("cavity_v_linf".into(), ev);
        self.errors.insert("cavity_linf".into(), eu.max(ev));
        let ke: f64 = fluid
            .iter()
            .map(|&i| 0.5 * p.mass[i] * p.v[i].norm_squared())
            .sum();
        let tu = l / u.abs();
        self.ke.push((sim.t, ke));
        self.ke
            .retain(|&(t, _)| t >= sim.t - STEADY_WINDOW * tu * (1.0 + 1e-9));
        let window = self.ke.first().map_or(0.0, |f| sim.t - f.0);
        if self.ke.len() >= 3 && window >= 0.99 * STEADY_WINDOW * tu {
            let n = self.ke.len() as f64;
            let (mt, me) = (
                self.ke.iter().map(|p| p.0).sum::<f64>() / n,
                self.ke.iter().map(|p| p.1).sum::<f64>() / n,
            );
            let sxx: f64 = self.ke.iter().map(|p| (p.0 - mt).powi(2)).sum();
            let sxy: f64 = self.ke.iter().map(|p| (p.0 - mt) * (p.1 - me)).sum();
            if me > 0.0 && sxx > 0.0 {
                let rate = (sxy / sxx).abs() * tu / me;
                self.errors.insert("kinetic_energy_rate".into(), rate);
                self.errors
                    .insert("steady".into(), if rate < STEADY_RATE { 1.0 } else { 0.0 });
            }
        }
    }
}

/// A fluid particle lies outside every wall particle's region: it is not closer to any wall
/// body's box than half a spacing inside it (checked against wall bodies of the scene).
fn inside_fluid_region<const D: usize>(sim: &View<D>, i: usize) -> bool {
    let x = sim.p.x[i];
    sim.scene.walls.iter().all(|w| {
        use crate::scene::WallShape;
        match w.shape {
            // the fluid must stay inside the inner box of a container (open faces excepted)
            WallShape::Container => (0..D).all(|a| {
                let lo_open = w
                    .open
                    .iter()
                    .any(|o| crate::scene::face_of(o, D) == Some((a, false)));
                let hi_open = w
                    .open
                    .iter()
                    .any(|o| crate::scene::face_of(o, D) == Some((a, true)));
                (lo_open || x[a] >= w.min[a]) && (hi_open || x[a] <= w.max[a])
            }),
            WallShape::Block => !(0..D).all(|a| x[a] >= w.min[a] && x[a] <= w.max[a]),
            WallShape::Polygon => !crate::scene::polygon::contains(&w.vertices, x[0], x[1]),
            WallShape::Mesh => !w.mesh.as_ref().is_some_and(|m| m.contains(x.as_slice())),
        }
    })
}

fn interpolate(series: &[(f64, f64)], t: f64) -> Option<f64> {
    let k = series.iter().position(|&(ts, _)| ts >= t)?;
    if k == 0 {
        return Some(series[0].1);
    }
    let (t0, f0) = series[k - 1];
    let (t1, f1) = series[k];
    Some(f0 + (f1 - f0) * (t - t0) / (t1 - t0).max(1e-300))
}

/// The Taylor–Green vortex at the view's time: (max over fluid particles of
/// |v − v_exact| / (U e^{bt}), the smallest distance between two fluid particles over Δx, and
/// the coefficient of variation of the nearest-neighbour distance — 0 on the initial lattice,
/// a measure of disorder). Distances wrap across the periodic box.
fn taylor_green_error<const D: usize>(sim: &View<D>, u: f64, l: f64) -> (f64, f64, f64) {
    let p = &sim.p;
    let (x0, y0) = (sim.scene.domain.min[0], sim.scene.domain.min[1]);
    let decay = (-8.0 * PI * PI * sim.model.nu / (l * l) * sim.t).exp();
    let k = 2.0 * PI / l;
    let fluid: Vec<usize> = (0..p.n_owned).filter(|&i| p.kind[i].is_fluid()).collect();
    let mut e: f64 = 0.0;
    for &i in &fluid {
        let (x, y) = (p.x[i][0] - x0, p.x[i][1] - y0);
        let ue = -u * decay * (k * x).cos() * (k * y).sin();
        let ve = u * decay * (k * x).sin() * (k * y).cos();
        let d = ((p.v[i][0] - ue).powi(2) + (p.v[i][1] - ve).powi(2)).sqrt();
        e = e.max(d / (u * decay));
    }
    let nearest = crate::probes::disorder::nearest_distances(p, &fluid, &periods(sim));
    let dx = sim.scene.discretisation.dx;
    let n = nearest.len().max(1) as f64;
    let mean = nearest.iter().sum::<f64>() / n;
    let var = nearest.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n;
    let dmin = nearest.iter().copied().fold(f64::INFINITY, f64::min);
    (e, dmin / dx, var.sqrt() / mean.max(1e-300))
}

/// Box length along each periodic axis of the view's scene (m), infinity along the others.
fn periods<const D: usize>(sim: &View<D>) -> Vec<f64> {
    let d = &sim.scene.domain;
    (0..D)
        .map(|a| match d.periodic.get(a) {
            Some(true) => d.max[a] - d.min[a],
            _ => f64::INFINITY,
        })
        .collect()
}

/// max over fluid particles of |u − u_exact| / u_max for the channel references.
fn channel_error<const D: usize>(sim: &View<D>, r: &Reference, gap: f64) -> f64 {
    let nu = sim.model.nu;
    let (umax, exact): (f64, Box<dyn Fn(f64) -> f64>) = match r {
        Reference::Poiseuille { .. } => {
            let f = sim.model.g[0];
            (
                f * gap * gap / (8.0 * nu),
                Box::new(move |y| poiseuille(y, sim.t, f, nu, gap)),
            )
        }
        Reference::Couette { v0, .. } => {
            let v0 = *v0;
            (v0, Box::new(move |y| couette(y, sim.t, v0, nu, gap)))
        }
        _ => unreachable!("channel references only"),
    };
    let mut e: f64 = 0.0;
    for i in 0..sim.p.n_owned {
        if sim.p.kind[i].is_fluid() {
            let y = sim.p.x[i][1];
            e = e.max((sim.p.v[i][0] - exact(y)).abs() / umax.abs());
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ghia_tables_give_their_interior_points() {
        let u = ghia(GHIA_U, 100);
        let v = ghia(GHIA_V, 100);
        assert_eq!((u.len(), v.len()), (15, 15));
        // Table I, Re = 100, y = 0.5: u = −0.20581; Table II, x = 0.2344: v = 0.17527
        assert!(u.iter().any(|&(y, g)| y == 0.5 && g == -0.20581), "{u:?}");
        assert!(v.iter().any(|&(x, g)| x == 0.2344 && g == 0.17527), "{v:?}");
        assert_eq!(ghia(GHIA_U, 1000).len(), 15);
        assert!(ghia(GHIA_U, 50).is_empty());
    }

    /// The series match the project's computed tables (docs/analytic.md §1).
    #[test]
    fn series_match_tabulated_centreline_values() {
        let (nu, l, f, v0) = (1e-6, 1e-3, 2e-4, 2.5e-5);
        for (t, up, uc) in [
            (0.0225, 4.4655e-6, 4.6055e-7),
            (0.1125, 1.6500e-5, 7.2569e-6),
            (0.5, 2.4814e-5, 1.2386e-5),
            (1.0, 2.4999e-5, 1.2499e-5),
        ] {
            assert!((poiseuille(l / 2.0, t, f, nu, l) - up).abs() < 1e-4 * up, "t={t}");
            assert!((couette(l / 2.0, t, v0, nu, l) - uc).abs() < 1e-4 * uc, "t={t}");
        }
        assert!(poiseuille(0.3e-3, 0.0, f, nu, l).abs() < 1e-12);
    }

    /// Linear theory doubles the wave at a wall; the second- and third-order terms add
    /// α²/2 + 3α³/4 (A/h = 0.2: 0.02 + 0.006).
    #[test]
    fn su_mirie_runup_at_a_fifth_of_the_depth() {
        assert!((su_mirie_runup(0.05, 0.25) - 0.25 * 0.426).abs() < 1e-15);
        assert!((su_mirie_runup(1e-6, 1.0) - 2e-6).abs() < 1e-11);
    }
}
