//! Dimension-wise factorisation `Nx·Ny(·Nz) = P` (seed 000, eqs. 4–5).

/// Relative window within which two values of `r_diff` count as a tie (see [`factorise`]).
pub const TIE_RELATIVE: f64 = 1e-12;

/// Edge-length difference of seed 000, eq. (5), in m:
/// `r_diff = max over axis pairs (a, b) of |e_a/n_a − e_b/n_b|`,
/// i.e. `max(|dx/Nx − dy/Ny|, |dy/Ny − dz/Nz|, |dz/Nz − dx/Nx|)` in 3D and `|dx/Nx − dy/Ny|` in 2D.
/// Equivalently the spread `max_a e_a/n_a − min_a e_a/n_a` of the block edge lengths.
///
/// # Panics
/// If `n` and `extents` differ in length or some `n` is zero.
pub fn r_diff(n: &[usize], extents: &[f64]) -> f64 {
    assert_eq!(n.len(), extents.len(), "one factor per axis");
    assert!(n.iter().all(|&k| k > 0), "factors must be positive");
    let mut worst = 0.0f64;
    for a in 0..n.len() {
        for b in a + 1..n.len() {
            let diff = (extents[a] / n[a] as f64 - extents[b] / n[b] as f64).abs();
            worst = worst.max(diff);
        }
    }
    worst
}

/// All ordered factorisations of `p` into `axes` positive factors, in lexicographic order.
pub fn ordered_factorisations(p: usize, axes: usize) -> Vec<Vec<usize>> {
    assert!(p > 0 && axes > 0);
    let mut out = Vec::new();
    let mut prefix = Vec::with_capacity(axes);
    fn rec(rest: usize, axes_left: usize, prefix: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if axes_left == 1 {
            prefix.push(rest);
            out.push(prefix.clone());
            prefix.pop();
            return;
        }
        for k in 1..=rest {
            if rest.is_multiple_of(k) {
                prefix.push(k);
                rec(rest / k, axes_left - 1, prefix, out);
                prefix.pop();
            }
        }
    }
    rec(p, axes, &mut prefix, &mut out);
    out
}

/// Factorisation `Nx·Ny(·Nz) = p` minimising `r_diff` (seed 000, eq. 5) for the extents
/// `dx, dy(, dz)` (m) of the particle cloud; any `p ≥ 1`, primes included (a prime gives
/// `p` slabs along the longest axis).
///
/// Every ordered factorisation is examined (the paper's "traverse all decompositions").
/// **Tie-break** (deterministic): among the factorisations whose `r_diff` lies within
/// `min·(1 + TIE_RELATIVE)` of the minimum (so that ties decided by rounding do not
/// depend on it), the lexicographically *largest* `(Nx, Ny, Nz)` wins: more cuts on the
/// outer axes, e.g. `[4, 3]` rather than `[3, 4]` for 12 ranks on a square. Outer (x) planes
/// span the whole domain and are found first, with the most particles per bisection.
///
/// # Panics
/// If `p == 0`, `extents` is empty, or an extent is negative or not finite.
pub fn factorise(p: usize, extents: &[f64]) -> Vec<usize> {
    assert!(p > 0, "need at least one rank");
    assert!(!extents.is_empty(), "need at least one axis");
    assert!(
        extents.iter().all(|e| e.is_finite() && *e >= 0.0),
        "extents must be finite and non-negative: {extents:?}"
    );
    let all = ordered_factorisations(p, extents.len());
    let best = all
        .iter()
        .map(|n| r_diff(n, extents))
        .fold(f64::INFINITY, f64::min);
    let window = best * (1.0 + TIE_RELATIVE);
    // `all` is in ascending lexicographic order: the last one inside the window wins.
    all.into_iter()
        .rev()
        .find(|n| r_diff(n, extents) <= window)
        .expect("the minimum itself lies in the window")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force written independently: nested loops over every divisor triple.
    fn brute_min(p: usize, e: &[f64]) -> f64 {
        let mut best = f64::INFINITY;
        match e.len() {
            2 => {
                for nx in 1..=p {
                    if p.is_multiple_of(nx) {
                        best = best.min((e[0] / nx as f64 - e[1] / (p / nx) as f64).abs());
                    }
                }
            }
            3 => {
                for nx in 1..=p {
                    for ny in 1..=p {
                        if p.is_multiple_of(nx * ny) {
                            let nz = p / (nx * ny);
                            let (a, b, c) = (e[0] / nx as f64, e[1] / ny as f64, e[2] / nz as f64);
                            best = best.min((a - b).abs().max((b - c).abs()).max((c - a).abs()));
                        }
                    }
                }
            }
            _ => unreachable!(),
        }
        best
    }

    const EXTENTS_2D: [[f64; 2]; 5] = [[1.0, 1.0], [4.0, 1.0], [0.3, 2.7], [1.0, 0.0], [1.6, 0.6]];
    const EXTENTS_3D: [[f64; 3]; 5] = [
        [1.0, 1.0, 1.0],
        [4.0, 1.0, 1.0],
        [3.2, 1.0, 0.6],
        [1.0, 1.0, 0.0],
        [0.5, 2.0, 8.0],
    ];

    fn check(p: usize, e: &[f64]) {
        let n = factorise(p, e);
        assert_eq!(n.len(), e.len());
        assert_eq!(n.iter().product::<usize>(), p, "product for p = {p}, e = {e:?}");
        let got = r_diff(&n, e);
        let min = brute_min(p, e);
        assert!(
            got <= min * (1.0 + TIE_RELATIVE),
            "p = {p}, e = {e:?}: {n:?} has {got} > {min}"
        );
        // Tie-break: no lexicographically larger factorisation is as good.
        for m in ordered_factorisations(p, e.len()) {
            if m > n {
                assert!(
                    r_diff(&m, e) > min * (1.0 + TIE_RELATIVE),
                    "{m:?} ties with {n:?}"
                );
            }
        }
    }

    #[test]
    fn decomp_factorise_matches_brute_force_2d_and_3d() {
        for p in 1..=128 {
            for e in EXTENTS_2D {
                check(p, &e);
            }
            for e in EXTENTS_3D {
                check(p, &e);
            }
        }
    }

    #[test]
    fn decomp_factorise_examples_and_primes() {
        assert_eq!(factorise(1, &[1.0, 1.0, 1.0]), vec![1, 1, 1]);
        assert_eq!(factorise(8, &[1.0, 1.0, 1.0]), vec![2, 2, 2]);
        assert_eq!(factorise(12, &[1.0, 1.0]), vec![4, 3]);
        assert_eq!(factorise(64, &[1.0, 1.0, 1.0]), vec![4, 4, 4]);
        assert_eq!(factorise(16, &[4.0, 1.0]), vec![8, 2]);
        for p in [2usize, 3, 5, 7, 11, 13, 97, 127] {
            // A prime goes to the longest axis (ties: the outer one).
            assert_eq!(factorise(p, &[1.0, 1.0]), vec![p, 1]);
            assert_eq!(factorise(p, &[1.0, 3.0]), vec![1, p]);
            assert_eq!(factorise(p, &[1.0, 0.5, 2.0]), vec![1, 1, p]);
        }
        assert_eq!(ordered_factorisations(12, 2).len(), 6);
        assert_eq!(ordered_factorisations(8, 3).len(), 10);
    }
}
