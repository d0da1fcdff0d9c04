"""A primal-dual interior-point method for one smooth inequality constraint.

Problem::

    minimise E(x)  subject to  c(x) >= 0,      x in R^n,

with ``E`` smooth and strictly convex (here the incremental potential of a time step, a quadratic
with a constant SPD Hessian ``H``) and ``c`` one smooth scalar constraint (the scene's smooth
distance). The method (Nocedal & Wright 2006, Ch. 19, specialised to one constraint and no
slack variable, so that **every iterate is feasible**, ``c(x_k) > 0``):

1. Barrier subproblems ``min E(x) - mu log c(x)`` for ``mu = mu0, sigma mu0, ...`` down to
   ``mu_min``, with the dual variable ``z`` (the contact force's magnitude) carried along.
2. One Newton step of the perturbed KKT system ``grad E - z grad c = 0``, ``c z = mu`` per
   iteration. Eliminating ``dz`` gives the primal-dual step::

       (H + (z / c) grad c grad c^T) dx = -(grad E - (mu / c) grad c)
       dz = (mu - c z - z grad c . dx) / c

   ``H`` is the true Hessian of ``E`` and the rank-one term is the constraint's Gauss-Newton
   (primal-dual) term; the constraint's own curvature ``-z hess c`` is dropped, which keeps the
   matrix SPD (the paper replaces the whole block by the identity). The SPD system is solved by
   Cholesky (``scipy.linalg.cho_factor``).
3. Backtracking line search (halving) on the barrier merit ``phi = E - mu log c``: a trial point
   is accepted only if ``c > 0`` there (feasibility) and Armijo's sufficient decrease holds
   (up to ``max_backtracks = 30`` halvings, steps down to ``2^-29``: with 5, a cube landing on
   an edge found no feasible trial at step 106 of ``tests/data/authors_sims/cube_plane.json``
   and stopped dead for a step, where the authors' simulator, which halves without a limit,
   went on; with 30 our path follows theirs to 9e-3 over all 120 steps);
   when no trial within ``max_backtracks`` halvings satisfies Armijo (the constraint gradient
   of edge and triangle meshes is approximate in rotation), the longest feasible trial that
   lowers the merit at all is taken; when there is none, ``mu`` is lowered, and at ``mu_min``
   the solve ends there (stationary to the accuracy of the gradient).
   The dual step uses the fraction-to-boundary rule (``tau = 0.995``) and is kept inside
   ``[mu / (kappa c), kappa mu / c]`` (``kappa = 1e10``, as in IPOPT).
4. The solve also ends at ``mu_min`` when an accepted step lowers the merit by less than
   ``1e-12`` of its value. A subproblem is solved when the accepted step is shorter than
   ``max(tol, 0.3 sqrt(mu))`` in the ``H`` norm; then ``mu <- max(sigma mu, mu_min)``. The solve
   ends when ``mu = mu_min`` and the step is below ``tol``. At the end ``c ~ mu_min / z`` when the
   contact is active.

Lengths: with ``H`` scaled to unit mass (the integrator divides by the mean mass), ``sqrt(dx^T H
dx)`` is a length, ``mu`` a squared length and ``z`` a length, so the tolerances are geometric.
"""

import math
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from tracer.errors import InfeasibleStart

TAU = 0.995
KAPPA = 1e10
ARMIJO = 1e-4


class IPMResult(NamedTuple):
    """x (n,), z (the multiplier), c at x, iterations, constraint evaluations, converged flag,
    the smallest ``c`` of every evaluated iterate (accepted or trial point: all are > 0)."""

    x: np.ndarray
    z: float
    c: float
    iterations: int
    evaluations: int
    converged: bool
    min_c: float


def solve(x0, energy, hessian, constraint, *, mu0, mu_min, tol, sigma=0.2, max_iter=100,
          max_backtracks=30, on_iterate=None, start=None):
    """Minimise ``energy`` subject to ``constraint >= 0`` from a feasible ``x0``.

    Parameters
    ----------
    x0 : (n,) float
        Feasible start, ``c(x0) > 0`` (else :class:`~tracer.errors.InfeasibleStart`).
    energy : callable x -> (E float, grad (n,))
    hessian : callable x -> (n, n) SPD matrix
    constraint : callable x -> (c float, grad (n,))
    mu0, mu_min, tol : float
        First and last barrier parameter, step tolerance (see module notes).
    on_iterate : callable(x, c), optional
        Called at every accepted iterate (tests check feasibility through it).
    start : (c, grad), optional
        The constraint at ``x0`` when the caller has it already.
    """
    x = np.array(x0, dtype=float)
    c, dc = start if start is not None else constraint(x)
    evals = 0 if start is not None else 1
    if not (math.isfinite(c) and c > 0):
        raise InfeasibleStart(f"the start is not feasible: constraint value {c:.6g} <= 0")
    mu = max(float(mu0), float(mu_min))
    z = mu / c
    min_c = c
    it = 0
    converged = False
    while it < max_iter:
        E, g = energy(x)
        H = hessian(x)
        K = H + (z / c) * np.outer(dc, dc)
        rhs = -(g - (mu / c) * dc)
        dx = cho_solve(cho_factor(K), rhs)
        dz = (mu - c * z - z * float(dc @ dx)) / c
        phi0 = E - mu * math.log(c)
        slope = float(-rhs @ dx)
        step = 1.0
        accepted = False
        fallback = None
        for _ in range(max_backtracks):
            xn = x + step * dx
            cn, dcn = constraint(xn)
            evals += 1
            if math.isfinite(cn) and cn > 0:
                min_c = min(min_c, cn)
                En = energy(xn)[0]
                phin = En - mu * math.log(cn)
                if phin <= phi0 + ARMIJO * step * slope + 1e-13 * abs(phi0):
                    accepted = True
                    break
                if fallback is None and phin < phi0:
                    fallback = (step, xn, cn, dcn, phin)
            step *= 0.5
        if not accepted and fallback is not None:
            # the gradient may be approximate (see tracer.sim.constraint): take the longest
            # feasible trial that lowered the merit at all
            step, xn, cn, dcn, phin = fallback
            accepted = True
        it += 1
        if not accepted:
            # no progress possible at this mu (the merit is flat to the accuracy of the
            # constraint's gradient): tighten mu, or stop at mu_min with the feasible x
            if mu <= mu_min:
                converged = True
                break
            mu = max(sigma * mu, mu_min)
            z = min(max(z, mu / (KAPPA * c)), KAPPA * mu / c)
            continue
        x, c, dc = xn, cn, dcn
        if on_iterate is not None:
            on_iterate(x, c)
        if mu <= mu_min and phi0 - phin <= 1e-12 * abs(phi0):
            converged = True                # the merit no longer changes: done
            break
        az = 1.0 if dz >= 0 else min(1.0, TAU * z / -dz)
        z = min(max(z + az * dz, mu / (KAPPA * c)), KAPPA * mu / c)
        length = step * math.sqrt(max(float(dx @ H @ dx), 0.0))
        if length <= max(tol, 0.3 * math.sqrt(mu)):
            if mu <= mu_min and length <= tol:
                converged = True
                break
            if mu > mu_min:
                mu = max(sigma * mu, mu_min)
                z = max(z, mu / (KAPPA * c))
    return IPMResult(x, z, c, it, evals, converged, min_c)
