"""Sharpness from the error you accept: ``alpha=within(max_error)``.

A solver author knows how far from the true gap its contact distance may read (a fraction of
its smallest feature, or of the step length), not which ``alpha`` gives it. :func:`within`
marks an error budget; every query that takes ``alpha`` then chooses the smallest alpha
(and, for whole meshes, ``alpha_q``) whose *proven* gap meets it.

The proof (scene units; ``N`` data primitives, ``A`` the weight bound, ``S`` the attenuation
exponent, ``L = S log A + log N``): every weight lies in ``[1, A^S]`` and a Barnes-Hut far field
stands for its primitives at a distance at least ``d_i / (1 + beta)`` (the acceptance rule
``diag < beta * delta``), so for a point query

    d / (1 + beta) - L / alpha  <=  d_hat  <=  d.

Where the exact distance ``d <= e`` this gives ``0 <= d - d_hat <= beta e / (1 + beta) +
L / alpha``, which is ``<= e`` once ``alpha >= (1 + beta) L / e``. So with
``alpha = within(e)``: wherever ``d <= e`` the smooth distance is at most ``e`` below the exact
one, and the surface ``d_hat = 0`` lies within ``e`` of the data. With ``beta = 0`` the gap is
at most ``e`` everywhere; with ``beta > 0`` it may grow to ``beta d / (1 + beta)`` far away,
where a solver's barrier is inactive.

For a query mesh of ``M`` primitives (:class:`~smoothdist.MeshDistance`, Eq. 6) the outer
LogSumExp adds at most ``log M / alpha_q``, so half of the budget goes to each:
``alpha = 2 (1 + beta) L / e`` and ``alpha_q = 2 (1 + beta) log M / e``. The inner bound holds
for point query primitives at any beta, and for edge and triangle query primitives when their
far fields use the exact primitive-box distance (``beta = 0``, or ``box_test=False``): the
paper's box test accepts a node on a lower bound of that distance (one axis's gap) that has no
such proven relation to ``d``, so :func:`mesh_alphas` refuses ``beta > 0`` with it.

The bound is attained: ``N`` data points at one spot read ``d_hat = d - log N / alpha`` at
``beta = 0`` (``tests/smoothdist/test_error_budget.py`` checks both sides). Real meshes sit well
inside it (a query sees a few primitives near, not all ``N``), so the chosen alpha is safe, not
tight.
"""

import math
from typing import NamedTuple

from smoothdist._cast import positive

class Within(NamedTuple):
    """An error budget in scene units, passed as ``alpha`` (see :func:`within`)."""

    max_error: float


def within(max_error):
    """``alpha=within(e)``: the smallest alpha whose proven gap ``d - d_hat`` is at most ``e``
    (scene units, > 0) wherever the exact distance ``d <= e`` (module notes).

    Accepted by :func:`smoothdist.smooth_distance`,
    :meth:`smoothdist.SmoothDistanceField.smooth_distance` and
    :meth:`~smoothdist.SmoothDistanceField.kernel_args` as ``alpha``, and by
    :class:`smoothdist.MeshDistance` and :func:`smoothdist.mesh_distance` as ``alpha`` (which
    then also chooses ``alpha_q``). :meth:`smoothdist.SmoothDistanceField.alpha_within`
    returns the number.

    Examples
    --------
    >>> import numpy as np, smoothdist as sd
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> d, g = sd.smooth_distance([[0.2, 0.2, 0.01]], V, [[0, 1, 2]], alpha=sd.within(0.002))
    >>> bool(0.01 - 0.002 <= d[0] <= 0.01)
    True
    """
    return Within(positive(max_error, "max_error"))


def alpha_for(max_error, beta, log_a, log_n, S=1.0, alpha_u=None):
    """The smallest ``alpha >= (1 + beta) (S log_a + log_n) / max_error``.

    ``log_a = log A`` and ``log_n = log N`` (>= 0). With a number ``alpha_u`` the exponent is
    ``S = min(alpha / alpha_u, 1)`` instead and the inequality is solved for alpha. When both
    logs are 0 (one point primitive) any alpha is exact; ``1 / max_error`` is returned.
    """
    c = (1.0 + beta) / max_error
    if alpha_u is None:
        alpha = c * (S * log_a + log_n)
    else:
        alpha_u = positive(alpha_u, "alpha_u")
        alpha = c * (log_a + log_n)              # S = 1: valid whenever alpha >= alpha_u
        den = 1.0 - c * log_a / alpha_u           # S = alpha / alpha_u below alpha_u
        if den > 0.0:
            a = c * log_n / den
            if a <= alpha_u:
                alpha = min(alpha, a)
    return max(alpha, 1.0 / max_error)


def point_alpha(field, budget, beta, alpha_u=None):
    """``alpha`` for point queries on ``field`` within ``budget`` (a :class:`Within`);
    ``alpha_u`` None (``S = 1``), ``"auto"`` (a fixed ratio to alpha, so a fixed ``S``) or a
    number."""
    log_a, log_n = math.log(field.weight_bound), math.log(field.num_primitives)
    if alpha_u is None:
        return alpha_for(budget.max_error, beta, log_a, log_n)
    if isinstance(alpha_u, str) and alpha_u == "auto":
        return alpha_for(budget.max_error, beta, log_a, log_n, S=1.0 / field.auto_alpha_u(1.0))
    return alpha_for(budget.max_error, beta, log_a, log_n, alpha_u=alpha_u)


def mesh_alphas(field, budget, beta, alpha_u, num_query_primitives, exact_far_field):
    """``(alpha, alpha_q)`` for a query mesh of ``num_query_primitives`` primitives, half of
    the budget each (module notes). ``exact_far_field``: the query's far fields use the exact
    primitive-box distance (point queries, ``box_test=False``); else ``beta`` must be 0."""
    if beta > 0.0 and not exact_far_field:
        raise ValueError(
            "alpha=within(...) for edge and triangle queries needs beta=0 or box_test=False: "
            "the paper's box test accepts far fields on a lower bound of their distance that "
            "has no proven error; pass beta=0 (exact sum) or box_test=False (exact box "
            "distances, the bound holds at any beta)")
    m = int(num_query_primitives)
    half = Within(budget.max_error / 2.0) if m > 1 else budget
    alpha = point_alpha(field, half, beta, alpha_u)
    alpha_q = alpha_for(half.max_error, beta, 0.0, math.log(m)) if m > 1 else alpha
    return alpha, alpha_q
