//! Particle disorder: each particle's distance to its nearest neighbour (brute force, every
//! pair once, the periodic images counted by the minimum-image rule), for the Taylor–Green
//! reference and the tensile-instability study's clumping index.

use crate::particles::Particles;

/// Distance (m) from each of the particles `ids` of `p` to the nearest other one of them.
/// `period[a]` is the box length along a periodic axis a (m), or infinity.
pub fn nearest_distances<const D: usize>(p: &Particles<D>, ids: &[usize], period: &[f64]) -> Vec<f64> {
    let pts: Vec<[f64; D]> = ids.iter().map(|&i| std::array::from_fn(|a| p.x[i][a])).collect();
    nearest_of(&pts, period)
}

/// [`nearest_distances`] of plain points.
pub fn nearest_of<const D: usize>(pts: &[[f64; D]], period: &[f64]) -> Vec<f64> {
    let mut best = vec![f64::INFINITY; pts.len()];
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            let mut r2 = 0.0;
            for a in 0..D {
                let mut d = pts[i][a] - pts[j][a];
                if period[a].is_finite() {
                    d -= period[a] * (d / period[a]).round();
                }
                r2 += d * d;
            }
            let r = r2.sqrt();
            best[i] = best[i].min(r);
            best[j] = best[j].min(r);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::nearest_of;

    /// A square lattice of spacing 0.1 in a periodic unit box: every nearest distance is the
    /// spacing, across the box's edges too; moving one point changes its pair's distances.
    #[test]
    fn nearest_distances_on_a_periodic_lattice() {
        let mut pts: Vec<[f64; 2]> = (0..100)
            .map(|k| [0.05 + 0.1 * (k % 10) as f64, 0.05 + 0.1 * (k / 10) as f64])
            .collect();
        let d = nearest_of(&pts, &[1.0, 1.0]);
        assert!(d.iter().all(|&r| (r - 0.1).abs() < 1e-12), "{d:?}");
        // the corner point moved towards the opposite corner's image
        pts[0] = [0.01, 0.05];
        let d = nearest_of(&pts, &[1.0, 1.0]);
        assert!((d[0] - 0.06).abs() < 1e-12, "{}", d[0]);
        assert!((d[9] - 0.06).abs() < 1e-12, "{}", d[9]);
        // without the period the image does not count: (0.05, 0.15) is nearest
        let d = nearest_of(&pts, &[f64::INFINITY, f64::INFINITY]);
        assert!((d[0] - (0.04f64.powi(2) + 0.01).sqrt()).abs() < 1e-12, "{}", d[0]);
        assert!((d[9] - 0.1).abs() < 1e-12, "{}", d[9]);
    }
}
