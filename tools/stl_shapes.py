#!/usr/bin/env python3
"""Write closed, outward-facing triangle meshes as STL files for `shape = "mesh"` (issue 83).

Shapes:
  box       --min X Y Z --max X Y Z               the 12 triangles of a block
  sphere    --centre X Y Z --radius R --bands N   a UV sphere, vertices on the radius
  cylinder  --centre X Y Z --radius R --length L --axis {0,1,2} --segments N
  wigley    --length L --beam B --draft T [--nx N --nz N]
            the Wigley hull y = B/2 (1 - (2x/L)^2)(1 - (z/T)^2), x in [-L/2, L/2], z in
            [-T, 0], closed by a deck at the waterline z = 0; its volume is 4/9 L B T.

Binary STL unless --ascii. Coordinates are written as the file's 32-bit floats; the script
prints the triangle count and the signed volume of what it wrote. Every shape here is convex,
so each triangle is turned to face away from the shape's centre.

Examples:
  python3 tools/stl_shapes.py box --min 0 0 0 --max 0.4 0.2 0.3 --out box.stl
  python3 tools/stl_shapes.py wigley --length 0.6 --beam 0.06 --draft 0.0375 --out inputs/meshes/wigley.stl
"""
import argparse
import math
import struct
import sys


def box(lo, hi):
    c = [[(lo, hi)[i & 1][0], (lo, hi)[(i >> 1) & 1][1], (lo, hi)[(i >> 2) & 1][2]] for i in range(8)]
    quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    tris = []
    for q in quads:
        tris += [[c[q[0]], c[q[1]], c[q[2]]], [c[q[0]], c[q[2]], c[q[3]]]]
    return tris, [(a + b) / 2 for a, b in zip(lo, hi)]


def sphere(centre, r, n):
    def at(i, j):
        if i == 0 or i == n:
            return [centre[0], centre[1], centre[2] + (r if i == 0 else -r)]
        th, ph = math.pi * i / n, 2 * math.pi * (j % (2 * n)) / (2 * n)
        return [centre[0] + r * math.sin(th) * math.cos(ph), centre[1] + r * math.sin(th) * math.sin(ph),
                centre[2] + r * math.cos(th)]
    tris = []
    for i in range(n):
        for j in range(2 * n):
            a, b, c, d = at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)
            if i != 0:
                tris.append([a, b, d])
            if i != n - 1:
                tris.append([b, c, d])
    return tris, centre


def cylinder(centre, r, length, axis, n):
    u, v = [(axis + 1) % 3, (axis + 2) % 3]

    def at(k, end):
        p = list(centre)
        if k is not None:
            ang = 2 * math.pi * (k % n) / n
            p[u] += r * math.cos(ang)
            p[v] += r * math.sin(ang)
        p[axis] += length / 2 * end
        return p
    tris = []
    for k in range(n):
        tris += [[at(k, -1), at(k + 1, -1), at(k + 1, 1)], [at(k, -1), at(k + 1, 1), at(k, 1)],
                 [at(None, -1), at(k + 1, -1), at(k, -1)], [at(None, 1), at(k, 1), at(k + 1, 1)]]
    return tris, centre


def wigley(length, beam, draft, nx, nz):
    def y(x, z):
        f = beam / 2 * (1 - (2 * x / length) ** 2) * (1 - (z / draft) ** 2)
        return max(f, 0.0)
    xs = [length / 2 * (2 * i / nx - 1) for i in range(nx + 1)]
    zs = [-draft * (1 - j / nz) for j in range(nz + 1)]
    tris = []
    for side in (1.0, -1.0):
        pt = lambda i, j: [xs[i], side * y(xs[i], zs[j]) + 0.0, zs[j]]
        for i in range(nx):
            for j in range(nz):
                a, b, c, d = pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1)
                # a panel at the bow, stern or keel whose corners all lie on y = 0 is the same
                # on both sides: the pair would be a fin of no volume, so neither is written
                tris += [t for t in ([a, b, c], [a, c, d]) if any(p[1] != 0.0 for p in t)]
    # the deck at the waterline, a fan of quads across the beam
    for i in range(nx):
        a, b = [xs[i], y(xs[i], 0.0), 0.0], [xs[i + 1], y(xs[i + 1], 0.0), 0.0]
        c, d = [xs[i + 1], -b[1] + 0.0, 0.0], [xs[i], -a[1] + 0.0, 0.0]
        tris += [[a, b, c], [a, c, d]]
    return tris, [0.0, 0.0, -draft / 2]


def f32(x):
    return struct.unpack('<f', struct.pack('<f', x))[0]


def sub(a, b):
    return [a[k] - b[k] for k in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def outward(tris, centre):
    """The triangles in 32-bit floats, without those of no area, each facing away from centre."""
    out = []
    for t in tris:
        t = [[f32(c) + 0.0 for c in p] for p in t]
        n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
        if n == [0.0, 0.0, 0.0]:
            continue
        mid = [sum(p[k] for p in t) / 3 for k in range(3)]
        if sum(n[k] * (mid[k] - centre[k]) for k in range(3)) < 0:
            t = [t[0], t[2], t[1]]
        out.append(t)
    return out


def volume(tris):
    return sum(sum(a * b for a, b in zip(t[0], cross(t[1], t[2]))) for t in tris) / 6


def write(path, tris, ascii_):
    if ascii_:
        with open(path, 'w') as f:
            f.write('solid hsph\n')
            for t in tris:
                n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
                f.write('facet normal %r %r %r\n outer loop\n' % tuple(n))
                for p in t:
                    f.write('  vertex %r %r %r\n' % tuple(p))
                f.write(' endloop\nendfacet\n')
            f.write('endsolid hsph\n')
        return
    with open(path, 'wb') as f:
        f.write(b'hsph tools/stl_shapes.py'.ljust(80, b' '))
        f.write(struct.pack('<I', len(tris)))
        for t in tris:
            n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
            f.write(struct.pack('<12fH', *n, *t[0], *t[1], *t[2], 0))


def main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('shape', choices=['box', 'sphere', 'cylinder', 'wigley'])
    p.add_argument('--out', required=True, help='the STL file to write')
    p.add_argument('--ascii', action='store_true', help='ASCII STL instead of binary')
    p.add_argument('--min', type=float, nargs=3)
    p.add_argument('--max', type=float, nargs=3)
    p.add_argument('--centre', type=float, nargs=3, default=[0.0, 0.0, 0.0])
    p.add_argument('--radius', type=float)
    p.add_argument('--bands', type=int, default=48, help='sphere: bands pole to pole')
    p.add_argument('--length', type=float)
    p.add_argument('--axis', type=int, default=2, choices=[0, 1, 2])
    p.add_argument('--segments', type=int, default=180, help='cylinder: segments round')
    p.add_argument('--beam', type=float)
    p.add_argument('--draft', type=float)
    p.add_argument('--nx', type=int, default=120, help='wigley: panels along the length')
    p.add_argument('--nz', type=int, default=24, help='wigley: panels down the draft')
    a = p.parse_args(argv)
    need = {'box': ['min', 'max'], 'sphere': ['radius'], 'cylinder': ['radius', 'length'],
            'wigley': ['length', 'beam', 'draft']}[a.shape]
    missing = [k for k in need if getattr(a, k) is None]
    if missing:
        p.error('%s needs --%s' % (a.shape, ' --'.join(missing)))
    if a.shape == 'box':
        tris, c = box(a.min, a.max)
    elif a.shape == 'sphere':
        tris, c = sphere(a.centre, a.radius, a.bands)
    elif a.shape == 'cylinder':
        tris, c = cylinder(a.centre, a.radius, a.length, a.axis, a.segments)
    else:
        tris, c = wigley(a.length, a.beam, a.draft, a.nx, a.nz)
    tris = outward(tris, c)
    write(a.out, tris, a.ascii)
    print('%s: %d triangles, volume %.6e m^3' % (a.out, len(tris), volume(tris)))


if __name__ == '__main__':
    main(sys.argv[1:])
