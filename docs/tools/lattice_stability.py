#!/usr/bin/env python3
"""Linear (von Neumann) stability of the 2D square SPH lattice under a uniform pressure p0.

Pure Python 3, no numpy. Mirrors hsph's discretisation (src/physics/fluid.rs, src/kernel.rs):
  momentum   dv_i/dt = -sum_j m (p_i/rho_i^2 + p_j/rho_j^2) gradW(x_ij)
  continuity drho_i/dt = sum_j m (v_i - v_j).gradW(x_ij)
             + delta h c0 sum_j V_j f_ij [-2(rho_j - rho_i) - (g_i + g_j).x_ij]   (delta-SPH)
             g_i = L_i sum_j (rho_j - rho_i) gradW V_j  (Antuono; g = 0 for Molteni)
  EOS        Tait p = B[(rho/rho0)^7 - 1], B = rho0 c0^2 / 7, linearised about rho_b = rho(p0).
Units: dx = 1, rho0 = 1, c0 = 1 (so omega is in c0/dx, p0 in rho0 c0^2), m = rho0 dx^2.

Perturbation xi_j = X e^{i k.x_j}, drho_j = R e^{i k.x_j}, r = x_i - x_j over lattice shells:
  S(k) = sum_j sin(k.r) gradW(r)            (real vector)
  M(k) = sum_j (1 - cos k.r) Hess W(r)      (real symmetric 2x2)
  F(k) = sum_j (1 - cos k.r) W'(r)/r
Without diffusion: omega^2 X = [m^2 beta S S^T + 2 m A0 M] X,
  beta = d(p/rho^2)/drho = c^2/rho_b^2 - 2 p0/rho_b^3,  A0 = p0/rho_b^2.
With delta-SPH the density relaxes at rate gamma(k) = -delta h c0 (2 V F + V^2 S^T L S)
(Antuono; Molteni drops the S^T L S term), and growth rates lambda (xi ~ e^{lambda t}) are
the roots of the quintic
  (gamma+lam)(lam^2+k1)(lam^2+k2) + a lam [s1^2 (lam^2+k2) + s2^2 (lam^2+k1)] = 0,
  k1,k2 = eigenvalues of K = 2 m A0 M, s = unit S in K's eigenbasis, a = m^2 beta |S|^2.

Run:  python3 docs/tools/lattice_stability.py            (table + fine scans, ~1 min)
      python3 docs/tools/lattice_stability.py --quick    (coarser k grid)
"""
import math
import cmath
import sys

PI = math.pi
GAMMA_TAIT = 7.0

# ---------------------------------------------------------------- kernels (h = 1 shapes)
KERNELS = {
    # name: (support factor, sigma_2D, f, f', f'')
    "wendland_c2": (2.0, 7.0 / (4.0 * PI)),
    "cubic_spline": (2.0, 10.0 / (7.0 * PI)),
    "quintic_spline": (3.0, 7.0 / (478.0 * PI)),
}


def shape(kind, q):
    """f(q), f'(q), f''(q) exactly as src/kernel.rs (f'' derived by hand, checked below)."""
    if kind == "wendland_c2":
        if q >= 2.0:
            return 0.0, 0.0, 0.0
        a = 1.0 - 0.5 * q
        return a ** 4 * (2 * q + 1), -5.0 * q * a ** 3, -5.0 * a * a * (1.0 - 2.0 * q)
    if kind == "cubic_spline":
        if q < 1.0:
            return 1 - 1.5 * q * q + 0.75 * q ** 3, -3 * q + 2.25 * q * q, -3 + 4.5 * q
        if q < 2.0:
            a = 2.0 - q
            return 0.25 * a ** 3, -0.75 * a * a, 1.5 * a
        return 0.0, 0.0, 0.0
    if kind == "quintic_spline":
        f = d1 = d2 = 0.0
        for c, s in ((1.0, 3.0), (-6.0, 2.0), (15.0, 1.0)):
            a = s - q
            if a > 0:
                f += c * a ** 5
                d1 += -5 * c * a ** 4
                d2 += 20 * c * a ** 3
        return f, d1, d2
    raise ValueError(kind)


def check_derivatives():
    for kind in KERNELS:
        for i in range(1, 60):
            q = i * KERNELS[kind][0] / 61.0
            e = 1e-5
            fd1 = (shape(kind, q + e)[0] - shape(kind, q - e)[0]) / (2 * e)
            fd2 = (shape(kind, q + e)[1] - shape(kind, q - e)[1]) / (2 * e)
            _, d1, d2 = shape(kind, q)
            assert abs(fd1 - d1) < 1e-5 * max(1, abs(d1)), (kind, q)
            assert abs(fd2 - d2) < 1e-4 * max(1, abs(d2)), (kind, q)
        # normalisation in 2D (midpoint rule)
        sup, sig = KERNELS[kind]
        n = 20000
        s = sum(sig * shape(kind, (i + 0.5) * sup / n)[0] * 2 * PI * (i + 0.5) * sup / n * sup / n
                for i in range(n))
        assert abs(s - 1) < 1e-6, (kind, s)


# ---------------------------------------------------------------- lattice sums
def shells(kind, hdx):
    """Neighbours r = (a, b) (dx = 1) with |r| < support, and W', W'', W'/r there."""
    sup, sig = KERNELS[kind]
    h = hdx
    rs = sup * h
    n = int(rs) + 1
    out = []
    for a in range(-n, n + 1):
        for b in range(-n, n + 1):
            if a == 0 and b == 0:
                continue
            r = math.hypot(a, b)
            if r >= rs:
                continue
            _, d1, d2 = shape(kind, r / h)
            w1 = sig / h ** 2 / h * d1          # dW/dr
            w2 = sig / h ** 2 / h ** 2 * d2     # d2W/dr2
            out.append((a, b, r, w1, w2, w1 / r))
    return out


def sums(sh, kx, ky):
    S = [0.0, 0.0]
    M = [[0.0, 0.0], [0.0, 0.0]]
    F = 0.0
    for a, b, r, w1, w2, f in sh:
        ph = kx * a + ky * b
        s, c1 = math.sin(ph), 1.0 - math.cos(ph)
        ex, ey = a / r, b / r
        S[0] += s * w1 * ex
        S[1] += s * w1 * ey
        # Hessian = W'' e e^T + (W'/r)(I - e e^T)
        hxx = w2 * ex * ex + f * (1 - ex * ex)
        hyy = w2 * ey * ey + f * (1 - ey * ey)
        hxy = (w2 - f) * ex * ey
        M[0][0] += c1 * hxx
        M[1][1] += c1 * hyy
        M[0][1] += c1 * hxy
        F += c1 * f
    M[1][0] = M[0][1]
    return S, M, F


def renorm_L(sh, V):
    """L = [sum_j V gradW (x) (x_j - x_i)]^-1 = [-V sum f r r^T]^-1 (isotropic on the lattice)."""
    bxx = -V * sum(f * a * a for a, b, r, w1, w2, f in sh)
    byy = -V * sum(f * b * b for a, b, r, w1, w2, f in sh)
    bxy = -V * sum(f * a * b for a, b, r, w1, w2, f in sh)
    det = bxx * byy - bxy * bxy
    return [[byy / det, -bxy / det], [-bxy / det, bxx / det]]


def sym_eig(A):
    """Eigenvalues (ascending) and eigenvectors of a real symmetric 2x2."""
    a, b, d = A[0][0], A[0][1], A[1][1]
    tr, disc = 0.5 * (a + d), math.hypot(0.5 * (a - d), b)
    l1, l2 = tr - disc, tr + disc
    if abs(b) > 1e-300:
        v1 = (b, l1 - a)
    else:
        v1 = (1.0, 0.0) if a <= d else (0.0, 1.0)
    nv = math.hypot(*v1)
    v1 = (v1[0] / nv, v1[1] / nv)
    v2 = (-v1[1], v1[0])
    return (l1, v1), (l2, v2)


def poly_roots(c):
    """Roots of monic polynomial c[0] x^n + ... + c[n] (Aberth/Durand-Kerner)."""
    n = len(c) - 1
    c = [x / c[0] for x in c]
    rad = 1 + max(abs(x) for x in c[1:])
    z = [rad * cmath.exp(2j * PI * (i + 0.25) / n) * 0.9 for i in range(n)]

    def p(x):
        v = 0j
        for co in c:
            v = v * x + co
        return v

    for _ in range(500):
        moved = 0.0
        for i in range(n):
            den = 1 + 0j
            for j in range(n):
                if j != i:
                    den *= (z[i] - z[j])
            if den == 0:
                den = 1e-30
            dz = p(z[i]) / den
            z[i] -= dz
            moved = max(moved, abs(dz))
        if moved < 1e-15 * rad:
            break
    return z


def charpoly(A):
    """Faddeev-LeVerrier: coefficients [1, c1, ..., cn] of det(lam I - A)."""
    n = len(A)
    c = [1.0]
    Mk = [[0.0] * n for _ in range(n)]
    for k in range(1, n + 1):
        # M_k = A M_{k-1} + c_{k-1} I
        Mk = [[sum(A[i][l] * Mk[l][j] for l in range(n)) + (c[-1] if i == j else 0.0)
               for j in range(n)] for i in range(n)]
        AM = [[sum(A[i][l] * Mk[l][j] for l in range(n)) for j in range(n)] for i in range(n)]
        c.append(-sum(AM[i][i] for i in range(n)) / k)
    return c


def growth_rate(K, C, S, m, beta, g):
    """Largest Re(lam) of the linear system, state (xi_x, xi_y, v_x, v_y, R'):
    xi' = v;  v' = -K xi - C v - m beta S R';  R' ' = m S.v - g R'."""
    A = [[0, 0, 1, 0, 0],
         [0, 0, 0, 1, 0],
         [-K[0][0], -K[0][1], -C[0][0], -C[0][1], -m * beta * S[0]],
         [-K[1][0], -K[1][1], -C[1][0], -C[1][1], -m * beta * S[1]],
         [0, 0, m * S[0], m * S[1], -g]]
    return max(z.real for z in poly_roots(charpoly(A)))


# ---------------------------------------------------------------- analysis of one case
def analyse(kind, hdx, pi0, nk=40, delta=0.1, diffusion="antuono", alpha=0.02, av_on=0.5):
    """pi0 = p0/(rho0 c0^2).  Returns
    w2min, k   : min omega^2 (c0/dx)^2 over the k grid, no diffusion, no viscosity
    Mmin, kM   : min eigenvalue of M(k) (pressure stiffness alone, p0 > 0 drives it)
    lam, klam  : largest growth rate (c0/dx) with delta-SPH (given variant), no viscosity
    lamav,kav  : same plus Monaghan artificial viscosity alpha, linearised and taken as
                 active a fraction av_on of the time (the real switch acts on approaching
                 pairs only; 0.5 = crude average, 1 = upper bound on damping)."""
    rho_b = (1.0 + GAMMA_TAIT * pi0) ** (1.0 / GAMMA_TAIT)
    c2 = rho_b ** (GAMMA_TAIT - 1.0)
    m = 1.0
    V = m / rho_b
    beta = c2 / rho_b ** 2 - 2 * pi0 / rho_b ** 3
    A0 = pi0 / rho_b ** 2
    sh = shells(kind, hdx)
    L = renorm_L(sh, V)
    h = hdx
    eta2 = 0.01 * h * h
    res = {"w2min": (float("inf"), None), "Mmin": (float("inf"), None),
           "lam": (0.0, None), "lamav": (0.0, None)}

    def keep(key, val, k, lower):
        if (val < res[key][0]) if lower else (val > res[key][0]):
            res[key] = (val, k)

    for i in range(nk + 1):
        for j in range(i, nk + 1):          # 0 <= kx <= ky <= pi suffices (square symmetry)
            if i == 0 and j == 0:
                continue
            kx, ky = PI * i / nk, PI * j / nk
            S, M, F = sums(sh, kx, ky)
            K = [[2 * m * A0 * M[p][q] for q in range(2)] for p in range(2)]
            Om = [[m * m * beta * S[p] * S[q] + K[p][q] for q in range(2)] for p in range(2)]
            keep("w2min", sym_eig(Om)[0][0], (kx, ky), True)
            keep("Mmin", sym_eig(M)[0][0], (kx, ky), True)
            if pi0 <= 0:
                continue
            sls = sum(S[p] * L[p][q] * S[q] for p in range(2) for q in range(2))
            g = -delta * h * (2 * V * F + (V * V * sls if diffusion == "antuono" else 0.0))
            zero = [[0.0, 0.0], [0.0, 0.0]]
            keep("lam", growth_rate(K, zero, S, m, beta, g), (kx, ky), False)
            if alpha > 0:
                D = [[0.0, 0.0], [0.0, 0.0]]
                for a, b, r, w1, w2, f in sh:
                    c1 = 1.0 - math.cos(kx * a + ky * b)
                    w = -av_on * m * alpha * h / rho_b * f * c1 / (r * r + eta2)
                    D[0][0] += w * a * a
                    D[0][1] += w * a * b
                    D[1][1] += w * b * b
                D[1][0] = D[0][1]
                keep("lamav", growth_rate(K, D, S, m, beta, g), (kx, ky), False)
    out = {}
    for key, (v, k) in res.items():
        out[key] = v
        out["k_" + key] = k
    return out


def fmt_k(k):
    return "(%.2f,%.2f)pi" % (k[0] / PI, k[1] / PI) if k else "-"


MEASURED = {
    "wendland_c2": "S R R S R S",
    "cubic_spline": "R S R R R R",
    "quintic_spline": "R S S R S S",
}
# onset times of the measured map (docs/validation.md (d)), s; None = stable to 2 s
ONSET = {
    "wendland_c2": [None, 0.2, 0.4, None, 0.1, None],
    "cubic_spline": [0.2, None, 0.65, 0.1, 0.05, 0.05],
    "quintic_spline": [0.75, None, None, 0.05, None, None],
}
HS = [1.0, 1.2, 1.3, 1.5, 1.7, 2.0]
# tank: p0 = rho0 g H with H = 0.5 m, c0 = 35 m/s
PI0_TANK = 1000 * 9.81 * 0.5 / (1000 * 35.0 ** 2)
C0_OVER_DX = 35.0 / 0.02


LAM_TOL = 1e-6   # growth rates below this (c0/dx units; 0.0035 e-folds in 2 s) = neutral


def main():
    quick = "--quick" in sys.argv
    nk = 20 if quick else 40
    check_derivatives()
    tol = 1e-12
    print("p0/(rho0 c0^2) at the tank bottom = %.5f; growth rates below in 1/s "
          "(lam * c0/dx, c0/dx = 1750/s); e = e-folds in 2 s" % PI0_TANK)
    print("\n== Table (p0 = rho0 g 0.5 m): omega^2 in (c0/dx)^2")
    print("kernel h/dx | p0=0 min w2 | p0=tank min w2 @k | min eig M @k | pred |"
          " lam Antuono | lam Molteni | lam Antuono+AV(0.5) e | measured")
    agree = 0
    total = 0
    for kind in KERNELS:
        meas = MEASURED[kind].split()
        for hdx, ms, ton in zip(HS, meas, ONSET[kind]):
            r0 = analyse(kind, hdx, 0.0, nk, delta=0.0)
            r1 = analyse(kind, hdx, PI0_TANK, nk, delta=0.1, diffusion="antuono")
            rm = analyse(kind, hdx, PI0_TANK, nk, delta=0.1, diffusion="molteni", alpha=0.0)
            pred = "R" if r1["w2min"] < -tol else "S"
            total += 1
            agree += pred == ms
            lam = lambda x: x * C0_OVER_DX if x > LAM_TOL else 0.0
            print("%-14s %.2f | %+.1e | %+.2e @%s | %+.2e @%s | %s | %5.1f | %5.1f | %5.1f e=%4.1f | %s"
                  % (kind, hdx, r0["w2min"], r1["w2min"], fmt_k(r1["k_w2min"]), r1["Mmin"],
                     fmt_k(r1["k_Mmin"]), pred, lam(r1["lam"]), lam(rm["lam"]),
                     lam(r1["lamav"]), 2 * lam(r1["lamav"]),
                     ms + ("" if ton is None else " %.2fs (%.1f e-folds)" % (ton, ton * lam(r1["lamav"])))))
    print("agreement of sign(min omega^2) with the measured map: %d/%d" % (agree, total))

    print("\n== p0 scan (Wendland C2, h/dx=1.7): min w2 ~ p0, growth ~ sqrt(p0)")
    for pi0 in (1e-4, 1e-3, PI0_TANK, 1e-2):
        r = analyse("wendland_c2", 1.7, pi0, nk, delta=0.1)
        print("  p0/(rho0c0^2)=%.4f  min w2=%+.3e  lam=%.3e  lam+AV=%.3e"
              % (pi0, r["w2min"], r["lam"], r["lamav"]))

    print("\n== stable windows of h/dx (min omega^2 >= 0 everywhere), step 0.01, 1.00-2.20")
    for kind in KERNELS:
        ranges, cur = [], None
        for i in range(121):
            hdx = round(1.0 + 0.01 * i, 2)
            ok = analyse(kind, hdx, PI0_TANK, 24, delta=0.0, alpha=0.0)["w2min"] > -tol
            if ok:
                cur = [hdx, hdx] if cur is None else [cur[0], hdx]
            elif cur:
                ranges.append(tuple(cur))
                cur = None
        if cur:
            ranges.append(tuple(cur))
        print("  %-15s %s" % (kind, ranges))

    print("\n== fine scan h/dx 1.00-2.20 step 0.05, p0 = tank bottom (growth in 1/s)")
    kinds = list(KERNELS) if "--all" in sys.argv else ["wendland_c2"]
    for kind in kinds:
        print(kind)
        for i in range(25):
            hdx = 1.0 + 0.05 * i
            r = analyse(kind, hdx, PI0_TANK, nk, delta=0.1)
            print("  h/dx=%.2f  min w2=%+.2e @%s  minM=%+.2e  lam=%5.1f  lam+AV=%5.1f  %s"
                  % (hdx, r["w2min"], fmt_k(r["k_w2min"]), r["Mmin"],
                     r["lam"] * C0_OVER_DX, r["lamav"] * C0_OVER_DX,
                     "UNSTABLE" if r["w2min"] < -tol else "stable"))


if __name__ == "__main__":
    main()
