"""The ripple metric: how far a render's normals stray from the analytic shape a mesh stands for.

A user's mesh is usually a tessellation of a smooth shape (an icosphere of a sphere, a
polyline of a circle, points sampled on a torus). Where the rendered surface has dimples or
ribs along the tessellation (issue 35), its normals turn away from the shape's. For a render
``res`` of such data and the analytic shape (one of the classes below), at every hit pixel
``p = origin + t dir``:

    angle(p) = angle between res.normals at p and the shape's unit normal at its point
               closest to p (outward for a closed surface; ``(p - q) / |p - q|`` for a curve
               with closest point ``q``)

and :func:`ripple` reports its percentiles (p50, p95, in degrees). The reference is the exact
distance's offset surface at the same mean offset (:func:`mean_offset`: the mean exact
distance from the smooth render's hit points to the data): its normals are exact for the
tessellation, so its angles show what the tessellation alone costs.

``benchmarks/bench_ripple.py`` renders the cases users meet (trimesh and pyvista shapes, as
triangles, edges and points) and writes the table. Shapes take and return ``(n, 3)`` float64
arrays; nothing here compiles a kernel (:class:`RoundedCube` needs scipy, the ``sim``
extra).
"""

import numpy as np

from tracer.rendering.camera import pixel_points

__all__ = ["Sphere", "Capsule", "Torus", "Box", "RoundedCube", "Circle", "Helix", "Segments",
           "hit_points", "normal_angles", "ripple", "mean_offset"]


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


class Sphere:
    """Sphere of ``radius`` about ``centre``."""

    def __init__(self, radius=1.0, centre=(0.0, 0.0, 0.0)):
        self.radius = float(radius)
        self.centre = np.asarray(centre, dtype=np.float64)

    def normals(self, P):
        """Outward unit normal at the point of the sphere closest to each row of ``P``."""
        return _unit(np.asarray(P, dtype=np.float64) - self.centre)

    def distance(self, P):
        """Signed distance (positive outside)."""
        return np.linalg.norm(np.asarray(P, dtype=np.float64) - self.centre, axis=1) - self.radius


class Capsule:
    """The points within ``radius`` of the segment ``a b``."""

    def __init__(self, a, b, radius):
        self.a = np.asarray(a, dtype=np.float64)
        self.b = np.asarray(b, dtype=np.float64)
        self.radius = float(radius)

    def _axis_point(self, P):
        ab = self.b - self.a
        s = np.clip((np.asarray(P, dtype=np.float64) - self.a) @ ab / (ab @ ab), 0.0, 1.0)
        return self.a + s[:, None] * ab

    def normals(self, P):
        return _unit(np.asarray(P, dtype=np.float64) - self._axis_point(P))

    def distance(self, P):
        return np.linalg.norm(np.asarray(P, dtype=np.float64) - self._axis_point(P), axis=1) \
            - self.radius


class Circle:
    """Circle of radius ``R`` in the plane ``z = 0`` about the origin (a curve; with
    :class:`Torus` its tube)."""

    def __init__(self, R):
        self.R = float(R)

    def closest(self, P):
        P = np.asarray(P, dtype=np.float64)
        xy = _unit(np.c_[P[:, 0], P[:, 1]])
        return np.c_[self.R * xy, np.zeros(len(P))]

    def normals(self, P):
        return _unit(np.asarray(P, dtype=np.float64) - self.closest(P))

    def distance(self, P):
        return np.linalg.norm(np.asarray(P, dtype=np.float64) - self.closest(P), axis=1)


class Torus(Circle):
    """Torus about the z axis: the points within ``r`` of the circle of radius ``R``."""

    def __init__(self, R, r):
        super().__init__(R)
        self.r = float(r)

    def distance(self, P):
        return super().distance(P) - self.r


class Box:
    """Axis-aligned box ``|x_i - c_i| <= h_i`` (sharp edges)."""

    def __init__(self, half, centre=(0.0, 0.0, 0.0)):
        self.half = np.asarray(half, dtype=np.float64)
        self.centre = np.asarray(centre, dtype=np.float64)

    def normals(self, P):
        """Outside: from the closest point of the box (the box's own normal on a face, a
        direction between the faces' next to an edge or corner); inside: the normal of the
        nearest face."""
        Q = np.asarray(P, dtype=np.float64) - self.centre
        out = _unit(Q - np.clip(Q, -self.half, self.half))
        excess = np.abs(Q) - self.half
        inside = np.all(excess <= 0, axis=1)
        k = np.argmax(excess[inside], axis=1)
        n = np.zeros((int(inside.sum()), 3))
        n[np.arange(len(k)), k] = np.sign(Q[inside, k])
        out[inside] = n
        return out

    def distance(self, P):
        Q = np.abs(np.asarray(P, dtype=np.float64) - self.centre) - self.half
        return np.linalg.norm(np.maximum(Q, 0.0), axis=1) + np.minimum(Q.max(axis=1), 0.0)


class RoundedCube:
    """The superellipsoid ``x^4 + y^4 + z^4 = radius^4`` (pyvista's
    ``ParametricSuperEllipsoid(n1=0.5, n2=0.5)`` for radius 1), about ``centre``.

    The closest point is found from a dense sample of the surface (``samples`` per face
    side, projected radially from a cube), then refined by alternating a move in the
    tangent plane and a Newton projection onto the surface."""

    def __init__(self, radius=1.0, centre=(0.0, 0.0, 0.0), samples=300):
        from scipy.spatial import cKDTree  # scipy (sim extra): loaded on use

        self.radius = float(radius)
        self.centre = np.asarray(centre, dtype=np.float64)
        u = np.linspace(-1.0, 1.0, samples)
        a, b = (g.ravel() for g in np.meshgrid(u, u))
        faces = []
        for axis in range(3):
            for sign in (-1.0, 1.0):
                f = np.empty((a.size, 3))
                f[:, axis] = sign
                f[:, (axis + 1) % 3] = a
                f[:, (axis + 2) % 3] = b
                faces.append(f)
        C = np.concatenate(faces)
        self.samples = C / (np.sum(C ** 4, axis=1) ** 0.25)[:, None]   # on the unit surface
        self.tree = cKDTree(self.samples)

    @staticmethod
    def _grad(Q):
        return 4.0 * Q ** 3

    def closest(self, P, iterations=8):
        """Closest surface point to each row of ``P`` (world coordinates)."""
        X = (np.asarray(P, dtype=np.float64) - self.centre) / self.radius
        Q = self.samples[self.tree.query(X)[1]].copy()
        for _ in range(iterations):
            n = _unit(self._grad(Q))
            D = X - Q
            Q = Q + D - np.sum(D * n, axis=1, keepdims=True) * n   # along the tangent plane
            for _ in range(3):                                      # back onto F = 1
                g = self._grad(Q)
                F = np.sum(Q ** 4, axis=1) - 1.0
                Q = Q - (F / np.sum(g * g, axis=1))[:, None] * g
        return Q * self.radius + self.centre

    def normals(self, P):
        Q = (self.closest(P) - self.centre) / self.radius
        return _unit(self._grad(Q))

    def distance(self, P):
        P = np.asarray(P, dtype=np.float64)
        Q = self.closest(P)
        inside = np.sum(((P - self.centre) / self.radius) ** 4, axis=1) < 1.0
        d = np.linalg.norm(P - Q, axis=1)
        return np.where(inside, -d, d)


class Helix:
    """The curve ``(R cos s, R sin s, pitch s / 2 pi)`` for ``0 <= s <= 2 pi turns``; the
    closest point by a dense sample of ``s`` refined by Newton steps on ``|p - c(s)|^2``."""

    def __init__(self, R, pitch, turns, samples=20000):
        self.R, self.pitch, self.turns = float(R), float(pitch), float(turns)
        self.s = np.linspace(0.0, 2 * np.pi * self.turns, samples)

    def point(self, s):
        s = np.asarray(s, dtype=np.float64)
        return np.stack([self.R * np.cos(s), self.R * np.sin(s),
                         self.pitch * s / (2 * np.pi)], axis=-1)

    def closest(self, P):
        P = np.asarray(P, dtype=np.float64)
        C = self.point(self.s)
        best = np.empty(len(P), dtype=np.int64)
        for i in range(0, len(P), 512):      # (512, samples) distance blocks
            blk = P[i:i + 512]
            d2 = (np.sum(blk ** 2, axis=1)[:, None] - 2 * blk @ C.T
                  + np.sum(C ** 2, axis=1)[None, :])
            best[i:i + 512] = np.argmin(d2, axis=1)
        s = self.s[best]
        k = self.pitch / (2 * np.pi)
        for _ in range(6):
            c, sn = np.cos(s), np.sin(s)
            D = self.point(s) - P
            d1 = np.c_[-self.R * sn, self.R * c, np.full_like(s, k)]
            d2 = np.c_[-self.R * c, -self.R * sn, np.zeros_like(s)]
            f1 = np.sum(D * d1, axis=1)
            f2 = np.sum(d1 * d1, axis=1) + np.sum(D * d2, axis=1)
            s = np.clip(s - f1 / np.where(f2 > 0, f2, np.inf), self.s[0], self.s[-1])
        return self.point(s)

    def normals(self, P):
        return _unit(np.asarray(P, dtype=np.float64) - self.closest(P))

    def distance(self, P):
        return np.linalg.norm(np.asarray(P, dtype=np.float64) - self.closest(P), axis=1)


class Segments:
    """A set of straight segments ``V[E]`` (a wireframe): the shape is the segments
    themselves; closest points by brute force in numpy."""

    def __init__(self, V, E):
        self.A = np.asarray(V, dtype=np.float64)[np.asarray(E)[:, 0]]
        self.B = np.asarray(V, dtype=np.float64)[np.asarray(E)[:, 1]]

    def closest(self, P):
        P = np.asarray(P, dtype=np.float64)
        AB = self.B - self.A
        L2 = np.sum(AB * AB, axis=1)
        out = np.empty_like(P)
        for i in range(0, len(P), 256):
            blk = P[i:i + 256]
            s = np.clip(np.einsum("pk,ek->pe", blk, AB) - np.sum(self.A * AB, axis=1), 0.0,
                        None) / L2
            s = np.minimum(s, 1.0)
            C = self.A[None] + s[..., None] * AB[None]              # (p, e, 3)
            d2 = np.sum((C - blk[:, None]) ** 2, axis=2)
            out[i:i + 256] = C[np.arange(len(blk)), np.argmin(d2, axis=1)]
        return out

    def normals(self, P):
        return _unit(np.asarray(P, dtype=np.float64) - self.closest(P))

    def distance(self, P):
        return np.linalg.norm(np.asarray(P, dtype=np.float64) - self.closest(P), axis=1)


# ---------------------------------------------------------------------------- the metric
def hit_points(res):
    """World positions ``(n, 3)`` of a render's hit pixels (row-major order of ``res.hit``)."""
    return pixel_points(res.camera, res.depth)[res.hit]


def normal_angles(res, shape):
    """Angle (degrees) between the rendered normal and ``shape``'s normal at its closest
    point, at every hit pixel of ``res`` (a :class:`tracer.RenderResult`), ``(n,)``."""
    P = hit_points(res)
    if not len(P):
        return np.zeros(0)
    ref = shape.normals(P)
    got = _unit(np.asarray(res.normals, dtype=np.float64)[res.hit])
    return np.degrees(np.arccos(np.clip(np.sum(got * ref, axis=1), -1.0, 1.0)))


def ripple(res, shape, percentiles=(50, 95)):
    """``{"p50": ..., "p95": ..., "hits": n}``: percentiles of :func:`normal_angles`
    (degrees; NaN without hits)."""
    a = normal_angles(res, shape)
    out = {f"p{p:g}": (float(np.percentile(a, p)) if a.size else float("nan"))
           for p in percentiles}
    out["hits"] = int(a.size)
    return out


def mean_offset(res, field=None):
    """Mean exact distance from the hit points of ``res`` to the data (its first object's
    field unless ``field`` is given): the offset at which the exact render is compared."""
    field = field or res.scene.objects[0].field
    P = hit_points(res)
    if not len(P):
        return float("nan")
    return float(np.mean(field.exact_distance(P)[0]))
