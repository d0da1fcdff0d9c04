"""Generated geometry for simulation files (``"primitive": {"type": ..., ...}``).

Every generator returns a :class:`smoothdist.DataMesh` in its own coordinates (centred at the
origin unless stated); sizes are in scene units.

========================  ==================================================================
type                      parameters (defaults)
========================  ==================================================================
``icosphere``             ``radius`` (1), ``subdivisions`` (2): closed triangle sphere
``sphere_points``         ``radius`` (1), ``count`` (200): Fibonacci points on a sphere
``box``                   ``size`` ([1, 1, 1]): closed triangle box
``plane``                 ``size`` ([4, 4]), ``resolution`` (10), ``bumps`` (0 = flat),
                          ``bump_count`` (3): a square grid of triangles at z = 0 (height
                          ``bumps * sin * sin``), normal +z
``hemisphere_net``        ``radius`` (1), ``rings`` (4), ``segments`` (16): a wire bowl (edges)
                          of latitude rings and meridians, the lower half-sphere, open at z = 0
``ring_toss``             ``base_radius`` (1), ``peg_height`` (1), ``peg_radius`` (0.08),
                          ``spacing`` (0.1): a point cloud of a disc at z = 0 and a vertical peg
``trefoil``               ``scale`` (1), ``segments`` (60): a closed trefoil-knot polyline
``point``                 none: a single point at the origin
``segment_v``             ``half_width`` (1), ``depth`` (0.5): two edges forming a V in the
                          x-y plane, vertex at the origin, arms up (+y)
========================  ==================================================================
"""

import numpy as np

from smoothdist import DataMesh


def _icosphere(radius=1.0, subdivisions=2):
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=float(radius))
    return DataMesh(np.asarray(m.vertices), np.asarray(m.faces), name="icosphere")


def _sphere_points(radius=1.0, count=200):
    n = int(count)
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return DataMesh(float(radius) * np.c_[r * np.cos(phi), r * np.sin(phi), z], name="sphere_points")


def _box(size=(1.0, 1.0, 1.0)):
    import trimesh

    m = trimesh.creation.box(extents=np.asarray(size, float))
    return DataMesh(np.asarray(m.vertices), np.asarray(m.faces), name="box")


def _plane(size=(4.0, 4.0), resolution=10, bumps=0.0, bump_count=3):
    n = int(resolution)
    sx, sy = (float(v) for v in size)
    u, v = np.meshgrid(np.linspace(-0.5, 0.5, n + 1), np.linspace(-0.5, 0.5, n + 1), indexing="ij")
    z = float(bumps) * np.sin(np.pi * bump_count * (u + 0.5)) * np.sin(np.pi * bump_count * (v + 0.5))
    V = np.c_[sx * u.ravel(), sy * v.ravel(), z.ravel()]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    return DataMesh(V, F, name="plane")


def _hemisphere_net(radius=1.0, rings=4, segments=16):
    r = float(radius)
    V, E = [], []
    lat = np.linspace(0, np.pi / 2, int(rings) + 1)       # polar angle from the bottom pole
    phis = np.linspace(0, 2 * np.pi, int(segments), endpoint=False)
    V.append([0.0, 0.0, -r])
    ring_idx = [np.zeros(len(phis), int)]
    for th in lat[1:]:
        start = len(V)
        for ph in phis:
            V.append([r * np.sin(th) * np.cos(ph), r * np.sin(th) * np.sin(ph), -r * np.cos(th)])
        ids = np.arange(start, start + len(phis))
        ring_idx.append(ids)
        E += [[ids[k], ids[(k + 1) % len(ids)]] for k in range(len(ids))]
    for k in range(len(phis)):
        for a, b in zip(ring_idx[:-1], ring_idx[1:]):
            E.append([a[k], b[k]])
    E = np.unique(np.sort(np.array(E), axis=1), axis=0)
    return DataMesh(np.array(V), E, name="hemisphere_net")


def _ring_toss(base_radius=1.0, peg_height=1.0, peg_radius=0.08, spacing=0.1):
    h = float(spacing)
    pts = []
    g = np.arange(-base_radius, base_radius + 1e-9, h)
    X, Y = np.meshgrid(g, g)
    keep = X ** 2 + Y ** 2 <= base_radius ** 2
    pts.append(np.c_[X[keep], Y[keep], np.zeros(keep.sum())])
    nz = max(int(np.ceil(peg_height / h)), 1)
    nc = max(int(np.ceil(2 * np.pi * peg_radius / h)), 6)
    for z in np.linspace(h, peg_height, nz):
        a = np.linspace(0, 2 * np.pi, nc, endpoint=False)
        pts.append(np.c_[peg_radius * np.cos(a), peg_radius * np.sin(a), np.full(nc, z)])
    return DataMesh(np.concatenate(pts), name="ring_toss")


def _trefoil(scale=1.0, segments=60):
    s = np.linspace(0, 2 * np.pi, int(segments), endpoint=False)
    V = float(scale) / 3.0 * np.c_[np.sin(s) + 2 * np.sin(2 * s), np.cos(s) - 2 * np.cos(2 * s),
                                   -np.sin(3 * s)]
    n = len(s)
    return DataMesh(V, np.c_[np.arange(n), (np.arange(n) + 1) % n], name="trefoil")


def _point():
    return DataMesh(np.zeros((1, 3)), name="point")


def _segment_v(half_width=1.0, depth=0.5):
    V = np.array([[-half_width, depth, 0.0], [0.0, 0.0, 0.0], [half_width, depth, 0.0]])
    return DataMesh(V, [[0, 1], [1, 2]], name="segment_v")


GENERATORS = {"icosphere": _icosphere, "sphere_points": _sphere_points, "box": _box,
              "plane": _plane, "hemisphere_net": _hemisphere_net, "ring_toss": _ring_toss,
              "trefoil": _trefoil, "point": _point, "segment_v": _segment_v}


def make(spec):
    """Build a primitive from ``{"type": name, **parameters}`` (ValueError on bad input)."""
    spec = dict(spec)
    kind = spec.pop("type", None)
    if kind not in GENERATORS:
        raise ValueError(f"type must be one of {sorted(GENERATORS)}, got {kind!r}")
    try:
        return GENERATORS[kind](**spec)
    except TypeError as exc:
        raise ValueError(f"bad parameters for {kind}: {exc}") from None
