//! Wall loads as engineers read them (docs/pressure.md, "Loads"): from a pressure series p(t)
//! (Pa, s), its raw maximum, its maximum after a centred box filter, and the impulse ∫p dt of
//! its first impact. One code for a run's pressure probes (`summary.json`) and for the
//! experiment's series (`hsph loads`), so both go through the same rules.
//!
//! The series is read as piecewise linear between its samples, which may be unevenly spaced
//! (a run's steps). Its integral I(t) = ∫_{t_0}^{t} p dt is exact for that reading (the
//! trapezoid rule), and every rule below is stated through it.

/// A pressure series: times (s, increasing) and values (Pa).
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    t: &'a [f64],
    p: &'a [f64],
    /// I(t_k), the integral up to each sample (Pa·s).
    cum: &'a [f64],
}

/// The loads of one pressure series.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Loads {
    /// The largest sample (Pa).
    pub raw_max: f64,
    /// Its time (s).
    pub raw_max_t: f64,
    /// The centred box filter's width (s).
    pub filter_s: f64,
    /// The largest value of the filtered series (Pa).
    pub filtered_max: f64,
    /// Its time (s).
    pub filtered_max_t: f64,
    /// The first impact's impulse (Pa·s) over `impulse_span_s` from `impulse_start_t`;
    /// `None` when no span was asked for, the pressure never stays above the threshold, or the
    /// record ends before the span does.
    pub impulse: Option<f64>,
    /// When the first impact starts (s).
    pub impulse_start_t: Option<f64>,
    /// The span the impulse is taken over (s).
    pub impulse_span_s: Option<f64>,
}

/// The fraction of the filtered peak the pressure must reach to start the first impact.
pub const IMPACT_FRACTION: f64 = 0.1;
/// How long (s) the pressure must stay at or above that fraction to start it: a spray
/// precursor shorter than this does not.
pub const IMPACT_HOLD_S: f64 = 1e-3;

/// The running integral I(t_k) of the series (t, p), trapezoid rule (Pa·s).
pub fn cumulative(t: &[f64], p: &[f64]) -> Vec<f64> {
    let mut cum = Vec::with_capacity(t.len());
    let mut s = 0.0;
    for k in 0..t.len() {
        if k > 0 {
            s += 0.5 * (p[k] + p[k - 1]) * (t[k] - t[k - 1]);
        }
        cum.push(s);
    }
    cum
}

impl<'a> Series<'a> {
    /// The series (t, p) with its running integral `cum` ([`cumulative`]). Times must increase.
    pub fn new(t: &'a [f64], p: &'a [f64], cum: &'a [f64]) -> Self {
        assert!(t.len() == p.len() && t.len() == cum.len());
        Series { t, p, cum }
    }

    /// p at time `x` (s), linear between samples, held beyond the ends.
    pub fn at(&self, x: f64) -> f64 {
        let k = self.t.partition_point(|&s| s <= x);
        if k == 0 {
            return self.p[0];
        }
        if k == self.t.len() {
            return self.p[k - 1];
        }
        let (t0, t1) = (self.t[k - 1], self.t[k]);
        self.p[k - 1] + (self.p[k] - self.p[k - 1]) * (x - t0) / (t1 - t0)
    }

    /// I(x) = ∫_{t_0}^{x} p dt (Pa·s) for x within the record.
    fn integral_to(&self, x: f64) -> f64 {
        let k = self.t.partition_point(|&s| s <= x);
        if k == 0 {
            return 0.0;
        }
        let j = k - 1;
        self.cum[j] + 0.5 * (self.p[j] + self.at(x)) * (x - self.t[j])
    }

    /// ∫_a^b p dt (Pa·s), a ≤ b, both clipped to the record.
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        let (t0, t1) = (self.t[0], self.t[self.t.len() - 1]);
        let (a, b) = (a.clamp(t0, t1), b.clamp(t0, t1));
        self.integral_to(b) - self.integral_to(a)
    }

    /// The centred box filter of width `w` (s) at every sample: the mean of p over
    /// [t_k − w/2, t_k + w/2] clipped to the record (Pa); p itself for w = 0.
    pub fn box_filter(&self, w: f64) -> Vec<f64> {
        let (t0, t1) = (self.t[0], self.t[self.t.len() - 1]);
        self.t
            .iter()
            .zip(self.p)
            .map(|(&tk, &pk)| {
                let (a, b) = ((tk - 0.5 * w).max(t0), (tk + 0.5 * w).min(t1));
                if b > a {
                    self.integral(a, b) / (b - a)
                } else {
                    pk
                }
            })
            .collect()
    }

    /// The start of the first impact: the first time the pressure reaches `threshold` (Pa;
    /// the crossing, linear between samples) and stays at or above it for `hold` seconds.
    pub fn first_sustained(&self, threshold: f64, hold: f64) -> Option<f64> {
        let n = self.t.len();
        let mut k = 0;
        while k < n {
            if self.p[k] < threshold {
                k += 1;
                continue;
            }
            // the crossing into this run of samples at or above the threshold
            let start = if k == 0 {
                self.t[0]
            } else {
                let (a, b) = (self.p[k - 1], self.p[k]);
                self.t[k - 1] + (self.t[k] - self.t[k - 1]) * (threshold - a) / (b - a)
            };
            let mut j = k;
            while j < n && self.p[j] >= threshold {
                j += 1;
            }
            // the run ends at the crossing out of it (or the record's end)
            let end = if j == n {
                self.t[n - 1]
            } else {
                let (a, b) = (self.p[j - 1], self.p[j]);
                self.t[j - 1] + (self.t[j] - self.t[j - 1]) * (a - threshold) / (a - b)
            };
            if end - start >= hold {
                return Some(start);
            }
            k = j;
        }
        None
    }

    /// The loads of the series: raw and filtered (width `filter`, s) maxima, and with
    /// `span` (s) the first impact's impulse, from [`first_sustained`](Self::first_sustained)
    /// at [`IMPACT_FRACTION`] of the filtered maximum held [`IMPACT_HOLD_S`], over `span`.
    pub fn loads(&self, filter: f64, span: Option<f64>) -> Loads {
        let argmax = |v: &[f64]| {
            v.iter().enumerate().fold(
                (0, f64::NEG_INFINITY),
                |m, (k, &x)| if x > m.1 { (k, x) } else { m },
            )
        };
        let (kr, raw) = argmax(self.p);
        let filtered = self.box_filter(filter);
        let (kf, fmax) = argmax(&filtered);
        let last = self.t[self.t.len() - 1];
        let start = span.and_then(|_| self.first_sustained(IMPACT_FRACTION * fmax, IMPACT_HOLD_S));
        let impulse = match (start, span) {
            (Some(s), Some(w)) if s + w <= last => Some(self.integral(s, s + w)),
            _ => None,
        };
        Loads {
            raw_max: raw,
            raw_max_t: self.t[kr],
            filter_s: filter,
            filtered_max: fmax,
            filtered_max_t: self.t[kf],
            impulse,
            impulse_start_t: impulse.and(start),
            impulse_span_s: span,
        }
    }
}

/// The loads of the series (t, p) ([`Series::loads`]); `None` for an empty series.
pub fn loads(t: &[f64], p: &[f64], filter: f64, span: Option<f64>) -> Option<Loads> {
    if t.is_empty() {
        return None;
    }
    let cum = cumulative(t, p);
    Some(Series::new(t, p, &cum).loads(filter, span))
}

/// The series (t, p) of columns `time` and `value` of the CSV file `path` (header first,
/// `#` lines skipped), times scaled by `t_scale` and values by `p_scale`, read within the
/// limits of a run's series ([`crate::limits::read_lines`]). Times must increase; a row
/// whose fields do not parse as finite numbers is an input error naming its line.
pub fn read_csv(
    path: &std::path::Path,
    (time, value): (&str, &str),
    (t_scale, p_scale): (f64, f64),
) -> crate::error::Result<(Vec<f64>, Vec<f64>)> {
    let (mut t, mut p) = (Vec::new(), Vec::new());
    let mut cols: Option<(usize, usize)> = None;
    let bad = |n: usize, m: String| crate::limits::file_error(path, value, Some(n), m);
    crate::limits::read_lines(path, "series", |n, line| {
        if line.starts_with('#') || line.trim().is_empty() {
            return Ok(());
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some((ct, cp)) = cols else {
            let at = |c: &str| fields.iter().position(|f| *f == c);
            match (at(time), at(value)) {
                (Some(a), Some(b)) => cols = Some((a, b)),
                _ => {
                    return Err(bad(
                        n,
                        format!("the header has no column `{time}` and `{value}`; it has {}", line),
                    ))
                }
            }
            return Ok(());
        };
        let num = |k: usize| {
            fields
                .get(k)
                .and_then(|f| f.parse::<f64>().ok())
                .filter(|x| x.is_finite())
        };
        let (Some(x), Some(y)) = (num(ct), num(cp)) else {
            return Err(bad(
                n,
                format!("`{time}` and `{value}` must be finite numbers: {line}"),
            ));
        };
        let x = x * t_scale;
        if t.last().is_some_and(|&l| x <= l) {
            return Err(bad(
                n,
                format!("times must increase: {x} s after {} s", t[t.len() - 1]),
            ));
        }
        t.push(x);
        p.push(y * p_scale);
        Ok(())
    })?;
    Ok((t, p))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uneven samples over [0, T]: the spacing varies by ±40 % (a run's steps).
    fn times(n: usize, t_end: f64) -> Vec<f64> {
        let mut t: Vec<f64> = (0..n)
            .map(|k| {
                let x = k as f64 / (n - 1) as f64;
                x + 0.4 * (6.0 * x).sin() / (6.0 * (n - 1) as f64)
            })
            .map(|x| x * t_end)
            .collect();
        t[n - 1] = t_end;
        t
    }

    /// The box filter of a linear ramp is the ramp wherever the box lies inside the record
    /// (the mean of a linear function over a centred interval is its centre value), and of a
    /// constant the constant everywhere.
    #[test]
    fn the_box_filter_keeps_ramps_and_constants() {
        let t = times(400, 0.1);
        let ramp: Vec<f64> = t.iter().map(|x| 3.0e4 * x + 50.0).collect();
        let cum = cumulative(&t, &ramp);
        let s = Series::new(&t, &ramp, &cum);
        let w = 0.004;
        for (k, f) in s.box_filter(w).iter().enumerate() {
            if t[k] > w && t[k] < 0.1 - w {
                assert!((f - ramp[k]).abs() <= 1e-9 * ramp[k], "{} against {}", f, ramp[k]);
            }
        }
        let flat = vec![7.5e3; t.len()];
        let cum = cumulative(&t, &flat);
        let s = Series::new(&t, &flat, &cum);
        assert!(s.box_filter(w).iter().all(|f| (f - 7.5e3).abs() <= 1e-9));
    }

    /// A triangle pulse of height A and half-width a through a box of width w ≤ a peaks at
    /// A (1 − w/(4a)), the mean over the box centred on the apex; the raw maximum is A.
    #[test]
    fn a_triangle_pulse_through_the_box_peaks_where_the_formula_says() {
        let (amp, a, w, c) = (2.0e4, 0.01, 0.004, 0.05);
        // samples on a grid that holds the apex and the box's edges around it
        let t: Vec<f64> = (0..=10_000).map(|k| k as f64 * 1e-5).collect();
        let p: Vec<f64> = t
            .iter()
            .map(|x| amp * (1.0 - (x - c).abs() / a).max(0.0))
            .collect();
        let l = loads(&t, &p, w, None).unwrap();
        assert_eq!(l.raw_max, amp);
        let want = amp * (1.0 - w / (4.0 * a));
        assert!(
            (l.filtered_max - want).abs() <= 1e-9 * amp,
            "{} against {want}",
            l.filtered_max
        );
        assert!((l.filtered_max_t - c).abs() < 1e-9);
    }

    /// The impulse of a half-sine pulse A sin(π(t − t_0)/T) over its whole span is 2AT/π; a
    /// precursor above the threshold for less than 1 ms does not start it.
    #[test]
    fn the_first_impacts_impulse_is_the_half_sines_and_a_precursor_does_not_start_it() {
        let (amp, dur, t0) = (1.0e4, 0.02, 0.03);
        let t = times(20_001, 0.1);
        let p: Vec<f64> = t
            .iter()
            .map(|&x| {
                let precursor = if (0.010..0.0105).contains(&x) {
                    0.5 * amp
                } else {
                    0.0
                };
                let pulse = if x > t0 && x < t0 + dur {
                    amp * (std::f64::consts::PI * (x - t0) / dur).sin()
                } else {
                    0.0
                };
                precursor + pulse
            })
            .collect();
        let thr = IMPACT_FRACTION * amp;
        // the start: where the half-sine reaches 10 % of its peak
        let start_want = t0 + dur * (IMPACT_FRACTION).asin() / std::f64::consts::PI;
        let cum = cumulative(&t, &p);
        let s = Series::new(&t, &p, &cum);
        let start = s.first_sustained(thr, IMPACT_HOLD_S).unwrap();
        assert!((start - start_want).abs() < 1e-6, "{start} against {start_want}");
        // over the pulse's own span from its start: everything but the sliver before it
        let l = loads(&t, &p, 0.0, Some(t0 + dur - start)).unwrap();
        let before =
            amp * dur / std::f64::consts::PI * (1.0 - (1.0 - IMPACT_FRACTION * IMPACT_FRACTION).sqrt());
        let want = 2.0 * amp * dur / std::f64::consts::PI - before;
        let got = l.impulse.unwrap();
        assert!((got - want).abs() <= 1e-6 * want, "{got} against {want}");
        assert!((l.impulse_start_t.unwrap() - start).abs() < 1e-9);
        // a span past the record's end gives no impulse
        assert_eq!(loads(&t, &p, 0.0, Some(0.2)).unwrap().impulse, None);
        // without the pulse the precursor alone (0.5 ms) never starts an impact
        let only: Vec<f64> = t
            .iter()
            .map(|&x| if (0.010..0.0105).contains(&x) { amp } else { 0.0 })
            .collect();
        assert_eq!(loads(&t, &only, 0.0, Some(0.01)).unwrap().impulse, None);
    }
}
