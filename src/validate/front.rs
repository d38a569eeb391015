//! The arithmetic of a sweep: which runs are on the Pareto front of cost against error, and
//! the convergence order fitted to error against resolution.

/// Indices of the points `(cost, error)` on the Pareto front: no other point is at least as
/// cheap and at least as accurate while strictly better in one of the two. Sorted by cost
/// (ties by error, then index). Points with a non-finite coordinate are never on the front.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        let (pa, pb) = (points[a], points[b]);
        pa.0.total_cmp(&pb.0).then(pa.1.total_cmp(&pb.1)).then(a.cmp(&b))
    });
    // walking by rising cost, a point is on the front when it beats every cheaper error
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// Least-squares order p and constant c of error ≈ c·dxᵖ over the pairs `(dx, error)` with
/// both positive and finite (log–log fit); `None` with fewer than two distinct dx.
pub fn convergence_order(pairs: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = pairs
        .iter()
        .filter(|(d, e)| *d > 0.0 && *e > 0.0 && d.is_finite() && e.is_finite())
        .map(|(d, e)| (d.ln(), e.ln()))
        .collect();
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return None;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 1e-24 {
        return None;
    }
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let p = sxy / sxx;
    Some((p, (my - p * mx).exp()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_what_nothing_beats() {
        // (cost, error): 1 dominates 3 (cheaper and better); 2 and 0 trade; 4 ties 0 in cost
        // but is worse; 5 is NaN
        let pts = [
            (1.0, 0.5),
            (0.5, 0.8),
            (4.0, 0.1),
            (2.0, 0.9),
            (1.0, 0.6),
            (f64::NAN, 0.0),
        ];
        assert_eq!(pareto(&pts), vec![1, 0, 2]);
        // equal points: the first one only
        assert_eq!(pareto(&[(1.0, 1.0), (1.0, 1.0)]), vec![0]);
        assert!(pareto(&[]).is_empty());
    }

    #[test]
    fn the_order_of_an_exact_power_law_is_recovered() {
        let pairs: Vec<(f64, f64)> = [0.1, 0.05, 0.025]
            .iter()
            .map(|&d: &f64| (d, 3.0 * d.powi(2)))
            .collect();
        let (p, c) = convergence_order(&pairs).unwrap();
        assert!((p - 2.0).abs() < 1e-12 && (c - 3.0).abs() < 1e-10, "{p} {c}");
        assert!(convergence_order(&[(0.1, 1.0)]).is_none());
        assert!(convergence_order(&[(0.1, 1.0), (0.1, 2.0)]).is_none());
        // non-positive errors are left out
        assert!(convergence_order(&[(0.1, 0.0), (0.05, 1.0)]).is_none());
    }
}
