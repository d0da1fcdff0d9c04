"""Rigid-body contact with one smooth-distance constraint (Madan & Levin 2022, Sec. 5.5).

Modules: :mod:`~tracer.sim.bodies` (bodies and mass properties), :mod:`~tracer.sim.primitives`
(generated geometry), :mod:`~tracer.sim.constraint` (the scene's single constraint),
:mod:`~tracer.sim.ipm` (primal-dual interior point), :mod:`~tracer.sim.integrator` (the time
step), :mod:`~tracer.sim.simfile` (simulation files), :mod:`~tracer.sim.run` (trajectories),
:mod:`~tracer.sim.animate` (frames, MP4, GIF), :mod:`~tracer.sim.frames` (the frames as
independent tasks for :mod:`tracer.runner`), :mod:`~tracer.sim.cli_simulate` and
:mod:`~tracer.sim.cli_animate` (``tracer simulate`` and ``tracer animate``),
:mod:`~tracer.sim.vbowl` (the paper's 2D V-bowl study).
"""

import importlib

_LAZY = {
    "load_simulation": "tracer.sim.simfile",
    "Simulation": "tracer.sim.simfile",
    "simulate": "tracer.sim.run",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    """The entry points, imported on first use (scipy loads only when needed). The movie
    writer is ``tracer.sim.animate.animate`` (not exported here: it would shadow its module)."""
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'tracer.sim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
