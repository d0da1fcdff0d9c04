"""Rigid bodies: geometry in a body frame, mass properties from that geometry, and the pose.

A :class:`Body` keeps its geometry as a :class:`smoothdist.DataMesh` in **body coordinates**:
the mesh's vertices with the centre of mass at the origin (axes unchanged). Its world pose is
``x_world = R @ X + x`` (``R (3, 3)`` rotation, ``x (3,)`` position of the centre of mass).

Mass properties (:func:`mass_properties`), ``density`` is per unit of the primitive's measure:

* **closed triangle meshes** (every edge shared by exactly two triangles): the solid's volume
  integrals (divergence theorem over signed tetrahedra to the origin), ``density`` per unit
  volume. The orientation of the triangles does not matter (the sign of the volume is taken).
* **open triangle meshes**: a thin shell, ``density`` per unit area.
* **edges**: a thin wire, ``density`` per unit length (exact integrals over each segment).
* **points**: a point mass ``density`` at each point.
* mixed meshes: the sum of their parts.

A body whose inertia is degenerate (a single point, collinear points, a single edge) gets its
missing principal moments raised to ``1e-3`` of the largest one (or to ``mass x 1`` for a single
point, whose orientation does not affect its geometry), so the rotational metric stays definite.
Inertia tensors are about the centre of mass, in kg m^2 if the inputs are kg and m.
"""

from dataclasses import dataclass, field

import numpy as np

from smoothdist import DataMesh, SmoothDistanceField

#: smallest principal moment relative to the largest (degenerate geometry, see module notes)
INERTIA_FLOOR = 1e-3


def _outer_sum(P):
    """``sum_i P_i P_i^T + (sum_i P_i)(sum_i P_i)^T`` for stacked vertex tuples ``P (m, k, 3)``."""
    s = P.sum(axis=1)
    return np.einsum("mki,mkj->mij", P, P) + np.einsum("mi,mj->mij", s, s)


def is_closed(T):
    """True when every undirected edge of triangles ``T (m, 3)`` is shared by exactly two."""
    if len(T) == 0:
        return False
    E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    _, counts = np.unique(E, axis=0, return_counts=True)
    return bool((counts == 2).all())


def _moments(mesh, density):
    """``(mass, first moment (3,), second moment C = int x x^T dm (3, 3))`` about the origin."""
    V = mesh.V
    m = 0.0
    first = np.zeros(3)
    C = np.zeros((3, 3))
    if mesh.points.size:
        P = V[mesh.points]
        m += density * P.shape[0]
        first += density * P.sum(axis=0)
        C += density * P.T @ P
    if len(mesh.edges):
        a, b = V[mesh.edges[:, 0]], V[mesh.edges[:, 1]]
        L = np.linalg.norm(b - a, axis=1)
        m += density * L.sum()
        first += density * (L[:, None] * 0.5 * (a + b)).sum(axis=0)
        C += density * np.einsum("m,mij->ij", L / 6.0, _outer_sum(np.stack([a, b], axis=1)))
    if len(mesh.triangles):
        P = V[mesh.triangles]
        if is_closed(mesh.triangles):
            vol = np.einsum("mi,mi->m", P[:, 0], np.cross(P[:, 1], P[:, 2])) / 6.0
            sign = 1.0 if vol.sum() >= 0 else -1.0
            vol = sign * vol
            m += density * vol.sum()
            # tetrahedron (0, a, b, c): int x dV = vol (a+b+c)/4; int x x^T dV = vol/20 (...)
            first += density * (vol[:, None] * P.sum(axis=1) / 4.0).sum(axis=0)
            C += density * np.einsum("m,mij->ij", vol / 20.0, _outer_sum(P))
        else:
            A = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
            m += density * A.sum()
            first += density * (A[:, None] * P.sum(axis=1) / 3.0).sum(axis=0)
            C += density * np.einsum("m,mij->ij", A / 12.0, _outer_sum(P))
    return m, first, C


def mass_properties(mesh, density=1.0):
    """Mass, centre of mass and inertia tensor of a :class:`~smoothdist.DataMesh` (see module
    notes).

    Returns ``(mass float, com (3,), inertia (3, 3))``; the inertia is about the centre of mass,
    symmetric positive definite (degenerate directions floored, see :data:`INERTIA_FLOOR`).
    Raises ``ValueError`` when the mass is not positive (e.g. a closed mesh of zero volume).
    """
    if not (np.isfinite(density) and density > 0):
        raise ValueError(f"density must be a finite number > 0, got {density!r}")
    m, first, C = _moments(mesh, float(density))
    if not m > 0:
        raise ValueError(f"{mesh.name}: the geometry has no mass (zero volume, length or area)")
    com = first / m
    C = C - m * np.outer(com, com)
    inertia = np.trace(C) * np.eye(3) - C
    inertia = 0.5 * (inertia + inertia.T)
    w, U = np.linalg.eigh(inertia)
    top = w.max()
    floor = INERTIA_FLOOR * top if top > 1e-12 * m * max(mesh.diagonal, 1e-300) ** 2 else m
    w = np.maximum(w, floor)
    return m, com, (U * w) @ U.T


def rotation_matrix(rotvec):
    """``exp([w]x)`` for a rotation vector ``w (3,)`` (Rodrigues)."""
    w = np.asarray(rotvec, dtype=float)
    th = float(np.linalg.norm(w))
    K = skew(w)
    if th < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th ** 2 * K @ K


def left_jacobian(rotvec):
    """SO(3) left Jacobian ``J(w)``: ``d/dw exp([w]x) y = -[exp([w]x) y]x J(w)``."""
    w = np.asarray(rotvec, dtype=float)
    th = float(np.linalg.norm(w))
    K = skew(w)
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return (np.eye(3) + (1 - np.cos(th)) / th ** 2 * K + (th - np.sin(th)) / th ** 3 * K @ K)


def skew(w):
    """The cross-product matrix ``[w]x`` with ``[w]x y = w x y``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


#: ``"alpha": "auto"`` in a simulation file: the body's rendered surface lies on average at
#: most this fraction of its thickness (smallest extent) from its mesh (see :func:`auto_alpha`)
AUTO_THICKNESS_OFFSET = 0.03


def thickness(mesh):
    """The body's smallest bounding-box extent, ignoring flat directions (a plane's 0): the
    length its smooth surface's offset is compared with."""
    ext = np.ptp(mesh.V, axis=0) if mesh.V.shape[0] else np.zeros(3)
    diag = float(np.linalg.norm(ext))
    solid = ext[ext > 1e-6 * diag]
    return float(solid.min()) if solid.size else max(diag, 1.0)


def auto_alpha(mesh, length, alpha_u="off"):
    """``"alpha": "auto"`` of a simulated body (1 / length).

    The library's ``alpha="auto"`` (mean surface offset <= 2 % of the body's diagonal) is
    raised until the estimated mean offset of the body's surface
    (:meth:`smoothdist.SmoothDistanceField.offset_estimate`, which over-estimates it at high
    alpha) is at most ``length``; a simulation file passes :data:`AUTO_THICKNESS_OFFSET` x
    the :func:`thickness` of its thinnest body, so that no drawn surface floats a visible
    fraction of a body above another (a capsule of radius 0.15 on a plane, both at alpha 40,
    rests 0.14 above it). Point clouds keep the library's value (their closure alpha: higher
    alphas open holes between the points). ``alpha_u``: ``"off"`` (no attenuation, the
    simulator's default) or ``"auto"``.
    """
    field = SmoothDistanceField(mesh)
    a = field.auto_alpha()
    if mesh.kind == "points":
        return a
    for _ in range(12):
        off = field.offset_estimate(a, alpha_u=a if alpha_u == "off" else "auto")
        if off <= length:
            break
        a *= 1.05 * off / length
    return float(a)


@dataclass
class Body:
    """One rigid body.

    Attributes
    ----------
    mesh : smoothdist.DataMesh
        In body coordinates (centre of mass at the origin).
    kind : {"points", "edges", "triangles", "mixed"}
    alpha, alpha_u : float
        Smooth-distance sharpness and attenuation threshold (1 / length).
    mass, inertia : float, (3, 3) float64
        kg, and the body-frame inertia tensor about the centre of mass.
    static : bool
        Static bodies never move (their mass properties are unused).
    x, R, v, w : (3,), (3, 3), (3,), (3,) float64
        World centre of mass, rotation, linear velocity, angular velocity (rad/s).
    offset : (3,) float64
        The centre of mass in the mesh file's coordinates (file vertex ``p`` sits at
        ``R (p - offset) + x``).
    """

    name: str
    mesh: DataMesh
    kind: str
    alpha: float
    alpha_u: float
    mass: float
    inertia: np.ndarray
    static: bool
    x: np.ndarray
    R: np.ndarray
    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    w: np.ndarray = field(default_factory=lambda: np.zeros(3))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def from_mesh(cls, mesh, *, name="body", alpha, alpha_u=None, density=1.0, position=(0, 0, 0),
                  rotation=None, velocity=(0, 0, 0), angular_velocity=(0, 0, 0), static=False):
        """A body from a mesh given in its file coordinates.

        The file's vertex ``p`` is placed at ``rotation @ p + position`` (``rotation`` a 3x3
        matrix, default identity); ``velocity`` is the centre of mass's, ``angular_velocity``
        is in world axes (rad/s).
        """
        mass, com, inertia = mass_properties(mesh, density)
        R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
                or np.linalg.det(R) <= 0:
            raise ValueError(f"{name}: rotation must be a 3x3 rotation matrix")
        local = DataMesh(mesh.V - com, points=mesh.points, edges=mesh.edges,
                         triangles=mesh.triangles, name=mesh.name, repair=False)
        x = R @ com + np.asarray(position, dtype=float)
        return cls(name=name, mesh=local, kind=mesh.kind, alpha=float(alpha),
                   alpha_u=float(alpha if alpha_u is None else alpha_u), mass=mass,
                   inertia=inertia, static=bool(static), x=x, R=R.copy(),
                   v=np.asarray(velocity, dtype=float).copy(),
                   w=np.asarray(angular_velocity, dtype=float).copy(), offset=com)

    @property
    def world_inertia(self):
        """``R I R^T`` (3, 3)."""
        return self.R @ self.inertia @ self.R.T

    def world_vertices(self, x=None, R=None):
        """The mesh's vertices at pose ``(x, R)`` (default: the current pose), ``(n, 3)``."""
        x = self.x if x is None else x
        R = self.R if R is None else R
        return self.mesh.V @ R.T + x

    @property
    def radius(self):
        """Largest distance of a referenced vertex from the centre of mass."""
        return float(np.linalg.norm(self.mesh.used_vertices(), axis=1).max())

    def kinetic_energy(self):
        """``1/2 m |v|^2 + 1/2 w . (R I R^T) w`` (J)."""
        if self.static:
            return 0.0
        return 0.5 * self.mass * float(self.v @ self.v) + 0.5 * float(self.w @ self.world_inertia
                                                                      @ self.w)

    def angular_momentum(self):
        """About the centre of mass, world axes: ``R I R^T w``."""
        return self.world_inertia @ self.w
