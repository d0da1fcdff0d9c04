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
``bowl_edges``            ``nlon`` (46), ``nrings`` (8), ``radius`` (1): the paper's wire bowl,
                          736 edges, open upwards (+y), rim at y = 0 (:func:`bowl_edges`)
``slide_edges``           ``nu`` (48), ``nv`` (7), ``length`` (4), ``radius`` (0.5), ``drop``
                          (1.5), ``n_edges`` (615): the paper's wire slide (:func:`slide_edges`)
``uv_sphere``             ``nlon`` (32), ``nlat`` (16), ``radius`` (0.3): 960 triangles
                          (:func:`uv_sphere`)
``ring_toss_board``       none: the paper's ring-toss point cloud, 12,400 points
                          (:func:`ring_toss_points`)
``lidar_terrain``         ``path`` (the shipped Autzen tile), ``copies`` (60), ``jitter`` (1),
                          ``z_jitter`` (0.1), ``tiles`` ([1, 1]), ``scale`` (0.05), ``z_scale``
                          (1), ``seed`` (0): a LiDAR tile densified (and optionally mirrored and
                          tiled) reproducibly; 6.6 million points by default
                          (:func:`lidar_terrain`)
========================  ==================================================================

The paper's Table 3 geometry (Madan & Levin 2022, Sec. 5.5) is generated here once, for the
mesh-distance benchmark (``benchmarks/bench_mesh_distance.py``) and the Table 3 simulations
(``scenes/simulations/table3/``): :func:`bowl_edges`, :func:`icosphere_edges`,
:func:`slide_edges`, :func:`uv_sphere`, :func:`ring_toss_points`, :func:`trefoil_100`,
:func:`spikes` and :func:`lidar_terrain`. These return arrays (``V`` and the edges or
triangles), deterministic for given parameters.
"""

import os

import numpy as np

from smoothdist import DataMesh
from smoothdist.mesh import read_mesh_file

#: the repository's ``scenes/data`` folder (the shipped data the defaults below refer to)
DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "scenes",
                    "data")
#: the LiDAR tile :func:`lidar_terrain` densifies by default (Autzen Stadium, feet, z up)
AUTZEN_TILE = os.path.normpath(os.path.join(DATA, "pointclouds", "lidar_autzen_trim.ply"))


def _icosphere(radius=1.0, subdivisions=2):
    import trimesh  # trimesh (tracer extra): loaded on use

    m = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=float(radius))
    return DataMesh(np.asarray(m.vertices), np.asarray(m.faces), name="icosphere")


def _sphere_points(radius=1.0, count=200):
    n = int(count)
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return DataMesh(float(radius) * np.c_[r * np.cos(phi), r * np.sin(phi), z],
                    name="sphere_points")


def _box(size=(1.0, 1.0, 1.0)):
    import trimesh  # trimesh (tracer extra): loaded on use

    m = trimesh.creation.box(extents=np.asarray(size, float))
    return DataMesh(np.asarray(m.vertices), np.asarray(m.faces), name="box")


def _plane(size=(4.0, 4.0), resolution=10, bumps=0.0, bump_count=3):
    n = int(resolution)
    sx, sy = (float(v) for v in size)
    u, v = np.meshgrid(np.linspace(-0.5, 0.5, n + 1), np.linspace(-0.5, 0.5, n + 1), indexing="ij")
    z = (float(bumps) * np.sin(np.pi * bump_count * (u + 0.5))
         * np.sin(np.pi * bump_count * (v + 0.5)))
    V = np.c_[sx * u.ravel(), sy * v.ravel(), z.ravel()]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                  idx[:-1, 1:].ravel())
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


# ------------------------------------------------------------------ the paper's Table 3 geometry
def resample_closed_polyline(V, E, n):
    """``n`` vertices and ``n`` edges evenly spaced by arc length along a closed polyline."""
    nxt = {int(a): int(b) for a, b in E}
    order = [int(E[0, 0])]
    while nxt[order[-1]] != order[0]:
        order.append(nxt[order[-1]])
    P = V[order + [order[0]]]
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    u = np.linspace(0, s[-1], n, endpoint=False)
    out = np.stack([np.interp(u, s, P[:, a]) for a in range(3)], axis=1)
    return out, np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)


#: the ``(x, z)`` centres of :func:`ring_toss_points`' pegs
RING_TOSS_PEGS = ((0.0, 0.0), (-1.2, -1.2), (1.2, -1.2), (-1.2, 1.2), (1.2, 1.2), (0.0, 1.5))


def ring_toss_points():
    """12,400 points: an 80 x 80 board (4 x 4 in the x-z plane at y = 0, spacing 0.05) and 6
    vertical pegs (+y, radius 0.1, height 1.6) of 1,000 points each."""
    g = (np.arange(80) + 0.5) * 0.05 - 2.0
    X, Z = np.meshgrid(g, g, indexing="ij")
    board = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], axis=1)
    pegs = []
    th = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    hs = (np.arange(50) + 0.5) * 0.032
    for cx, cz in RING_TOSS_PEGS:
        T, H = np.meshgrid(th, hs, indexing="ij")
        pegs.append(np.stack([cx + 0.1 * np.cos(T.ravel()), H.ravel(),
                              cz + 0.1 * np.sin(T.ravel())], axis=1))
    return np.concatenate([board] + pegs)



def trefoil_100(path=None):
    """The trefoil polyline of ``path`` (default: the shipped ``scenes/data/curves/trefoil.obj``)
    resampled to 100 edges, centred, scaled to a 2.0 bounding-box diagonal and laid flat (its
    thin axis becomes y)."""
    m = DataMesh.load(path or os.path.join(DATA, "curves", "trefoil.obj"))
    V, E = resample_closed_polyline(m.V, m.edges, 100)
    V = (V - V.mean(axis=0)) * (2.0 / np.linalg.norm(np.ptp(V, axis=0)))
    # lie flat: the knot's thin axis becomes y
    thin = int(np.argmin(np.ptp(V, axis=0)))
    perm = [a for a in range(3) if a != thin]
    V = V[:, [perm[0], thin, perm[1]]]
    return V, E


def bowl_edges(nlon=46, nrings=8, radius=1.0):
    """A hemispherical wire bowl: ``nrings`` latitude circles of ``nlon`` vertices plus
    meridians down to the bottom pole (``(0, -radius, 0)``): ``2 * nlon * nrings`` = 736 edges by
    default; open upwards (+y), rim at y = 0."""
    nlon, nrings = int(nlon), int(nrings)
    V = [[0.0, -radius, 0.0]]
    E = []
    for r in range(1, nrings + 1):
        phi = 0.5 * np.pi * r / nrings          # angle from the bottom pole
        for k in range(nlon):
            th = 2 * np.pi * k / nlon
            V.append([radius * np.sin(phi) * np.cos(th), -radius * np.cos(phi),
                      radius * np.sin(phi) * np.sin(th)])
    idx = lambda r, k: 1 + (r - 1) * nlon + (k % nlon)  # noqa: E731
    for r in range(1, nrings + 1):
        for k in range(nlon):
            E.append([idx(r, k), idx(r, k + 1)])                      # latitude circle
            E.append([0 if r == 1 else idx(r - 1, k), idx(r, k)])     # meridian
    return np.array(V), np.array(E)


def icosphere_edges(radius=0.25):
    """Icosphere (1 subdivision): 42 vertices, 120 unique edges."""
    import trimesh  # trimesh (tracer extra): loaded on use

    ico = trimesh.creation.icosphere(subdivisions=1, radius=radius)
    return np.asarray(ico.vertices), np.asarray(ico.edges_unique)


def slide_edges(nu=48, nv=7, length=4.0, radius=0.5, drop=1.5, n_edges=615):
    """A curved half-pipe chute as a wire grid (``nu`` along, ``nv`` across), trimmed to
    ``n_edges`` edges (the paper's 615). It runs from x = 0 (top, its axis at y = ``drop``) to
    x = ``length`` (bottom, axis at y = 0, level), bending sideways (z) on the way; vertex
    ``i * nv + j`` is ring ``i`` along, ``j`` across (``j = nv // 2`` the bottom line)."""
    nu, nv = int(nu), int(nv)
    u = np.linspace(0, 1, nu)
    a = np.linspace(-0.5 * np.pi, 0.5 * np.pi, nv)          # across the chute
    V = []
    for ui in u:
        x = length * ui
        y = drop * (1 - ui) ** 2
        yaw = 0.6 * np.sin(np.pi * ui)                         # gentle bend
        for aj in a:
            side = radius * np.sin(aj)
            V.append([x - side * np.sin(yaw), y - radius * np.cos(aj), side * np.cos(yaw)])
    V = np.array(V)
    idx = lambda i, j: i * nv + j  # noqa: E731
    E = []
    for i in range(nu):
        for j in range(nv):
            if j + 1 < nv:
                E.append([idx(i, j), idx(i, j + 1)])
            if i + 1 < nu:
                E.append([idx(i, j), idx(i + 1, j)])
    return V, np.array(E[:int(n_edges)])


def uv_sphere(nlon=32, nlat=16, radius=0.3):
    """Latitude-longitude sphere (poles on y): ``2 * nlon * (nlat - 1)`` = 960 triangles by
    default, closed, outward-facing."""
    nlon, nlat = int(nlon), int(nlat)
    V = [[0, radius, 0]]
    for i in range(1, nlat):
        th = np.pi * i / nlat
        for k in range(nlon):
            ph = 2 * np.pi * k / nlon
            V.append([radius * np.sin(th) * np.cos(ph), radius * np.cos(th),
                      radius * np.sin(th) * np.sin(ph)])
    V.append([0, -radius, 0])
    V = np.array(V, dtype=float)
    ring = lambda i, k: 1 + (i - 1) * nlon + (k % nlon)  # noqa: E731
    F = []
    south = len(V) - 1
    for k in range(nlon):
        F.append([0, ring(1, k + 1), ring(1, k)])
        F.append([south, ring(nlat - 1, k), ring(nlat - 1, k + 1)])
    for i in range(1, nlat - 1):
        for k in range(nlon):
            a, b = ring(i, k), ring(i, k + 1)
            c, d = ring(i + 1, k), ring(i + 1, k + 1)
            F.append([a, b, d])
            F.append([a, d, c])
    return V, np.array(F)


def spikes(radius=0.3, length=0.25):
    """Six spikes as edges along the coordinate axes, from ``radius`` (the vertices of
    :func:`uv_sphere` at the poles and on the equator at longitudes 0, 90, 180, 270 degrees) out
    to ``radius + length``: ``(V (12, 3), E (6, 2))``. With the default :func:`uv_sphere` the
    paper's spiky sphere (960 triangles + 6 edges = 966 primitives)."""
    D = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    V = np.concatenate([radius * D, (radius + length) * D])
    return V, np.stack([np.arange(6), np.arange(6) + 6], axis=1)


def lidar_terrain(path=None, copies=60, jitter=1.0, z_jitter=0.1, tiles=(1, 1), scale=0.05,
                  z_scale=1.0, seed=0):
    """A large terrain point cloud built reproducibly from a LiDAR tile: ``(N, 3)`` points.

    ``path``: a point file (default :data:`AUTZEN_TILE`, 110,000 points in feet, z up).

    1. **Tiling**: ``tiles = [nx, ny]`` mirrored copies side by side; copy ``(i, j)`` is the tile
       reflected in x when ``i`` is odd and in y when ``j`` is odd, so neighbours meet along
       their common edge and the ground is continuous across the seams (a point lying exactly on
       a seam is kept once).
    2. **Densifying**: every point is kept and ``copies - 1`` jittered copies of it are added:
       Gaussian offsets with standard deviation ``jitter`` horizontally and ``z_jitter``
       vertically (file units), drawn from ``numpy.random.default_rng(seed)``. This fills the
       gaps between scan lines (about 2 ft in the Autzen tile) so that a high ``alpha`` sees a
       closed surface; it blurs the ground by about ``jitter``.
    3. **Placing**: x and y centred on the bounding box of the tiled points, z measured from
       their lowest point (before jitter), all multiplied by ``scale`` and z also by
       ``z_scale``.

    ``N = n * copies * nx * ny`` less the seam points; the defaults give 110,000 x 60 =
    6,600,000 points (the paper's terrain has 6,591,087), 58.9 x 28.1 x 5.7 units.
    """
    if path is None:
        path = AUTZEN_TILE
    copies, nx, ny = int(copies), int(tiles[0]), int(tiles[1])
    if copies < 1 or nx < 1 or ny < 1:
        raise ValueError(f"copies and tiles must be >= 1, got {copies} and {list(tiles)}")

    P = np.asarray(read_mesh_file(os.fspath(path))[0], dtype=float)
    lo, hi = P.min(axis=0), P.max(axis=0)
    w = hi - lo
    U = P - lo
    parts = []
    for i in range(nx):
        for j in range(ny):
            Q = U.copy()
            keep = np.ones(len(Q), bool)
            for axis, k in ((0, i), (1, j)):
                if k % 2:
                    Q[:, axis] = w[axis] - Q[:, axis]
                if k > 0:                                   # the seam with copy k - 1
                    keep &= Q[:, axis] != 0.0
                Q[:, axis] += k * w[axis]
            parts.append(Q[keep])
    T = np.concatenate(parts)
    centre = np.array([0.5 * nx * w[0], 0.5 * ny * w[1], 0.0])
    T -= centre
    if copies > 1:
        rng = np.random.default_rng(int(seed))
        J = rng.standard_normal((len(T), copies - 1, 3))
        J *= np.array([jitter, jitter, z_jitter], float)
        J += T[:, None, :]
        T = np.concatenate([T[:, None, :], J], axis=1).reshape(-1, 3)
    T *= float(scale)
    T[:, 2] *= float(z_scale)
    return T


def _mesh(name, arrays):
    V, F = arrays
    return DataMesh(V, F, name=name)


def _bowl_edges(nlon=46, nrings=8, radius=1.0):
    return _mesh("bowl_edges", bowl_edges(nlon, nrings, float(radius)))


def _slide_edges(nu=48, nv=7, length=4.0, radius=0.5, drop=1.5, n_edges=615):
    return _mesh("slide_edges", slide_edges(nu, nv, float(length), float(radius), float(drop),
                                            n_edges))


def _uv_sphere(nlon=32, nlat=16, radius=0.3):
    return _mesh("uv_sphere", uv_sphere(nlon, nlat, float(radius)))


def _ring_toss_board():
    return DataMesh(ring_toss_points(), name="ring_toss_board")


def _lidar_terrain(path=None, copies=60, jitter=1.0, z_jitter=0.1, tiles=(1, 1), scale=0.05,
                   z_scale=1.0, seed=0):
    T = lidar_terrain(path, copies, jitter, z_jitter, tiles, scale, z_scale, seed)
    return DataMesh(T, name="lidar_terrain")


GENERATORS = {"icosphere": _icosphere, "sphere_points": _sphere_points, "box": _box,
              "plane": _plane, "hemisphere_net": _hemisphere_net, "ring_toss": _ring_toss,
              "trefoil": _trefoil, "point": _point, "segment_v": _segment_v,
              "bowl_edges": _bowl_edges, "slide_edges": _slide_edges, "uv_sphere": _uv_sphere,
              "ring_toss_board": _ring_toss_board, "lidar_terrain": _lidar_terrain}


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
