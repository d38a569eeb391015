#!/usr/bin/env python3
"""Steady lattice model of hsph's Poiseuille channel (docs/validation.md section 4).

The channel is periodic along x, so at steady state every particle of a row moves alike and
the laminar term (docs/equations.md 4.2-4.3) reduces to a linear system over the n rows,
y_k = (k + 1/2) dx, k = 0 .. n-1, between plates at y = 0 and y = L = n dx:

    F + 2 nu sum_j K(y_j - y_i) (u_i - u_j) / L_lat + wall terms = 0,
    K(dy) = sum over x offsets a dx of V (1/r) dW/dr,   V = dx^2,

where the wall terms come from the image rows behind each plate (depth d_j = (k + 1/2) dx):
    reflect  u_i - u_j' = u_i + u_j                  (mirror, no_slip = "adami")
    morris   u_i - u_j' = (1 + d_j/max(d_i, dx/2)) u_i   (no_slip = "morris", dummy or mirror)
and L_lat the square lattice's moment (renormalised operator) or 1 (plain Morris operator).
It prints the steady max |u - u_exact| / u_max for each kernel and h/dx of the sweep at the
resolutions asked: the part of the measured error that the discrete operator and the wall
make, with no time stepping, pressure or density noise.

Pure Python, no dependencies: python3 docs/tools/channel_model.py [n ...] (default 25).
"""
import math
import sys


def dw_dr(kind, h):
    """dW/dr (2D, normalised) of hsph's kernels and their support radius in units of h."""
    if kind == "cubic_spline":
        s = 10.0 / (7.0 * math.pi * h * h)

        def f(r):
            q = r / h
            if q < 1.0:
                return s * (-3.0 * q + 2.25 * q * q) / h
            if q < 2.0:
                return -0.75 * s * (2.0 - q) ** 2 / h
            return 0.0

        return f, 2.0
    if kind == "wendland_c2":
        s = 7.0 / (4.0 * math.pi * h * h)

        def f(r):
            q = r / h
            return -5.0 * s * q * (1.0 - q / 2.0) ** 3 / h if q < 2.0 else 0.0

        return f, 2.0
    s = 7.0 / (478.0 * math.pi * h * h)  # quintic spline

    def f(r):
        q = r / h
        t = 0.0
        if q < 3.0:
            t -= 5.0 * (3.0 - q) ** 4
        if q < 2.0:
            t += 30.0 * (2.0 - q) ** 4
        if q < 1.0:
            t -= 75.0 * (1.0 - q) ** 4
        return s * t / h

    return f, 3.0


def solve(a, b):
    """Gaussian elimination with partial pivoting."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(c + 1, n):
            f = m[r][c] / m[c][c]
            for k in range(c, n + 1):
                m[r][k] -= f * m[c][k]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (m[r][n] - sum(m[r][k] * x[k] for k in range(r + 1, n))) / m[r][r]
    return x


def channel_error(kind, h_over_dx, n, wall, renormalised):
    """Steady max |u - u_exact| / u_max of the Poiseuille channel (L = 1, F = nu = 1)."""
    dx = 1.0 / n
    h = h_over_dx * dx
    f, q = dw_dr(kind, h)
    reach = int(math.ceil(q * h / dx)) + 1
    area = dx * dx

    def row_kernel(dy):
        t = 0.0
        for a in range(-reach, reach + 1):
            r = math.hypot(a * dx, dy)
            if 0.0 < r < q * h:
                t += area * f(r) / r
        return t

    moment = 1.0
    if renormalised:
        moment = 0.0
        for a in range(-reach, reach + 1):
            for b in range(-reach, reach + 1):
                r = math.hypot(a * dx, b * dx)
                if 0.0 < r < q * h:
                    moment -= area * r * f(r) / 2.0
    y = [(k + 0.5) * dx for k in range(n)]
    mat = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(n):
            if i != j:
                k = 2.0 * row_kernel(y[j] - y[i]) / moment
                mat[i][i] += k
                mat[i][j] -= k
            # the image of row j behind each plate: (its y, its depth, row i's depth)
            for yj, dj, di in ((-y[j], y[j], y[i]), (2.0 - y[j], 1.0 - y[j], 1.0 - y[i])):
                k = 2.0 * row_kernel(yj - y[i]) / moment
                if k == 0.0:
                    continue
                if wall == "reflect":
                    mat[i][i] += k
                    mat[i][j] += k
                else:
                    mat[i][i] += k * (1.0 + dj / max(di, 0.5 * dx))
    u = solve(mat, [-1.0] * n)
    return max(abs(u[k] - 0.5 * y[k] * (1.0 - y[k])) for k in range(n)) / 0.125


def main():
    ns = [int(a) for a in sys.argv[1:]] or [25]
    variants = [
        ("quintic_spline", 1.0),
        ("quintic_spline", 1.5),
        ("cubic_spline", 1.2),
        ("cubic_spline", 2.0),
        ("wendland_c2", 1.2),
        ("wendland_c2", 2.0),
    ]
    print("steady Poiseuille error (% of u_max); columns: wall treatment / operator")
    head = ["reflect/plain", "reflect/renorm", "morris/renorm"]
    for n in ns:
        print(f"\nn = {n}")
        print(f"{'kernel':>16} {'h/dx':>5} " + " ".join(f"{c:>15}" for c in head))
        for kind, hdx in variants:
            e = [
                channel_error(kind, hdx, n, "reflect", False),
                channel_error(kind, hdx, n, "reflect", True),
                channel_error(kind, hdx, n, "morris", True),
            ]
            print(f"{kind:>16} {hdx:>5.1f} " + " ".join(f"{100 * x:>14.3f}%" for x in e))


if __name__ == "__main__":
    main()
