"""One time step of frictionless rigid-body contact: an incremental potential minimised subject to
the scene's single smooth-distance constraint (paper Sec. 5.5, after Ferguson et al. 2021).

Unknowns per moving body: the new centre of mass ``x`` and a rotation vector ``theta`` with the
new rotation ``R = exp([theta]x) R_t`` (a world-frame increment). The incremental potential is::

    E(x, theta) = sum_b  1/2 m_b |x_b - x^_b|^2
                       + 1/2 (theta_b - theta^_b)^T I_b (theta_b - theta^_b)
    x^ = x_t + h v_t + h^2 g,   theta^ = h w_t,   I_b = R_t I_body R_t^T   (world inertia at t)

Its unconstrained minimiser is ``x = x^`` (implicit Euler in position under gravity:
``v_{t+1} = v_t + h g``, ``x_{t+1} = x_t + h v_{t+1}``) and ``theta = h w_t``, i.e.
``R_{t+1} = exp(h [w_t]x) R_t`` (exponential Euler in orientation). With contact, the
constraint's force enters both. After the step::

    v_{t+1} = (x - x_t) / h,   L_{t+1} = I_b theta / h,   w_{t+1} = (R I_body R^T)^-1 L_{t+1}

so without torque the angular momentum ``L`` is conserved exactly and the translational energy
loses ``1/2 m h^2 |g|^2`` per step (implicit Euler's damping; it never grows in free flight).

The constraint's gradient with respect to ``theta`` is ``J_l(theta)^T gw`` (the SO(3) left
Jacobian, :func:`tracer.sim.bodies.left_jacobian`) with ``gw`` the world-rotation gradient of
:class:`~tracer.sim.constraint.ContactConstraint`. The energy is divided by the mean mass of the
moving bodies before the solve, so the interior-point tolerances are lengths
(:mod:`tracer.sim.ipm`):

* ``mu0 = z_lin max(c_t, 10 gap_tol)`` and ``mu_min = z_lin gap_tol`` with ``z_lin`` the contact
  force of the linearised problem (``Integrator._barrier_range``): the first barrier
  problem keeps the current gap ``c_t``, the last one leaves a gap of about ``gap_tol``,
* ``gap_tol = 1e-2 / alpha_min`` (the smallest alpha of a body in contact: the blur of the
  softest surface) and ``tol = 1e-2 * gap_tol`` unless given. The gap must stay above the
  jumps of the Barnes-Hut approximation (switching a node between near and far field makes the
  smooth distance jump by up to about ``1e-2 / alpha``; the paper's Sec. 4.4 study); a gap
  below them makes line searches fail. Scenes with large, coarse data (LiDAR) set ``gap_tol``.

If the unconstrained minimiser is feasible (``c > 0`` there) it *is* the constrained minimiser
(the energy is convex), and the step takes it with one constraint evaluation and no
interior-point iteration. Like the paper, there is no continuous collision detection: every
iterate and trial point is checked for ``c > 0``, so time steps must be small compared to
(feature size / speed).
"""

import time
from typing import NamedTuple

import numpy as np
from scipy.linalg import block_diag

from tracer.sim import ipm
from tracer.sim.bodies import left_jacobian, rotation_matrix


class StepStats(NamedTuple):
    """Per step: interior-point iterations, distance evaluations, constraint value at the end,
    smallest constraint value of any evaluated point, wall seconds, converged flag."""

    iterations: int
    evaluations: int
    c: float
    min_c: float
    seconds: float
    converged: bool


class Integrator:
    """Steps a list of bodies in place.

    Parameters
    ----------
    bodies : list of :class:`~tracer.sim.bodies.Body`
    constraint : :class:`~tracer.sim.constraint.ContactConstraint`
    gravity : (3,) m/s^2
    dt : float
        Time step ``h`` (s).
    gap_tol, tol : float, optional
        Interior-point tolerances (scene units), see module notes.
    """

    def __init__(self, bodies, constraint, gravity, dt, *, gap_tol=None, tol=None, max_iter=100):
        self.bodies = bodies
        self.constraint = constraint
        self.g = np.asarray(gravity, dtype=float)
        self.h = float(dt)
        self.dyn = [k for k, b in enumerate(bodies) if not b.static]
        if not self.dyn:
            raise ValueError("no body moves: mark at least one body as not static")
        self.mbar = float(np.mean([bodies[k].mass for k in self.dyn]))
        self.gap_tol = float(gap_tol) if gap_tol is not None else 1e-2 / constraint.alpha_min
        self.tol = float(tol) if tol is not None else 1e-2 * self.gap_tol
        self.max_iter = int(max_iter)
        self.time = 0.0
        self.on_iterate = None

    # ---------------------------------------------------------------- state <-> unknowns
    def _poses(self, q, X0, R0):
        X = X0.copy()
        Rs = R0.copy()
        for n, k in enumerate(self.dyn):
            X[k] = q[6 * n:6 * n + 3]
            Rs[k] = rotation_matrix(q[6 * n + 3:6 * n + 6]) @ R0[k]
        return X, Rs

    def constraint_at(self, q, X0, R0):
        """``(c, grad (6 n_dyn,))`` at unknowns ``q``."""
        X, Rs = self._poses(q, X0, R0)
        c, gx, gw = self.constraint.evaluate(X, Rs)
        grad = np.empty_like(q)
        for n, k in enumerate(self.dyn):
            grad[6 * n:6 * n + 3] = gx[k]
            grad[6 * n + 3:6 * n + 6] = left_jacobian(q[6 * n + 3:6 * n + 6]).T @ gw[k]
        return c, grad

    def current(self):
        """Centres ``(nb, 3)`` and rotations ``(nb, 3, 3)`` of all bodies now."""
        return (np.array([b.x for b in self.bodies]), np.array([b.R for b in self.bodies]))

    def _barrier_range(self, M, q0, qhat, c0, dc0):
        """``(mu0, mu_min)`` from the multiplier of the linearised problem.

        ``z_lin`` solves ``min 1/2 |q - q^|_M^2`` s.t. ``c0 + grad c0 . (q - q0) >= 0``; the first
        barrier problem keeps the current gap (``mu0 = z_lin max(c0, 10 gap_tol)``) and the last
        one leaves a gap of about ``gap_tol`` (``mu_min = z_lin gap_tol``).
        """
        w = np.linalg.solve(M, dc0)
        gw = float(dc0 @ w)
        z = -(c0 + float(dc0 @ (qhat - q0))) / gw
        if not z > 0:
            r = q0 - qhat
            z = 0.1 * float(np.sqrt(r @ M @ r)) / np.sqrt(gw)
        return z * max(c0, 10 * self.gap_tol), z * self.gap_tol

    # ---------------------------------------------------------------- one step
    def step(self):
        """Advance every moving body by ``dt``; returns :class:`StepStats`."""
        t0 = time.perf_counter()
        h = self.h
        X0, R0 = self.current()
        n = len(self.dyn)
        q0 = np.zeros(6 * n)
        qhat = np.zeros(6 * n)
        blocks = []
        Iw = []
        for i, k in enumerate(self.dyn):
            b = self.bodies[k]
            q0[6 * i:6 * i + 3] = b.x
            qhat[6 * i:6 * i + 3] = b.x + h * b.v + h * h * self.g
            qhat[6 * i + 3:6 * i + 6] = h * b.w
            I = b.world_inertia
            Iw.append(I)
            blocks.append(block_diag(b.mass * np.eye(3), I) / self.mbar)
        M = block_diag(*blocks)

        def energy(q):
            r = q - qhat
            Mr = M @ r
            return 0.5 * float(r @ Mr), Mr

        evals0 = self.constraint.evaluations
        c_hat, _ = self.constraint_at(qhat, X0, R0)
        if c_hat > 0:
            q, iters, conv, c_end, min_c = qhat, 0, True, c_hat, c_hat
        else:
            c0, dc0 = self.constraint_at(q0, X0, R0)
            mu0, mu_min = self._barrier_range(M, q0, qhat, c0, dc0)
            res = ipm.solve(q0, energy, lambda q: M, lambda q: self.constraint_at(q, X0, R0),
                            mu0=mu0, mu_min=mu_min, tol=self.tol, max_iter=self.max_iter,
                            on_iterate=self.on_iterate, start=(c0, dc0))
            q, iters, conv, c_end, min_c = res.x, res.iterations, res.converged, res.c, \
                min(res.min_c, c_hat if c_hat > 0 else np.inf)
        for i, k in enumerate(self.dyn):
            b = self.bodies[k]
            x_new = q[6 * i:6 * i + 3]
            th = q[6 * i + 3:6 * i + 6]
            U, _, Vt = np.linalg.svd(rotation_matrix(th) @ b.R)
            R_new = U @ Vt                      # re-orthonormalised against round-off drift
            L = Iw[i] @ th / h
            b.v = (x_new - b.x) / h
            b.x = x_new.copy()
            b.R = R_new
            b.w = np.linalg.solve(b.world_inertia, L)
        self.time += h
        return StepStats(iters, self.constraint.evaluations - evals0, float(c_end), float(min_c),
                         time.perf_counter() - t0, bool(conv))
