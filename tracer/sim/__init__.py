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

from tracer.lazy import attach_stub

# the entry points, imported on first use (scipy loads only when needed), listed in
# tracer/sim/__init__.pyi; the movie writer is tracer.sim.animate.animate (not exported here:
# it would shadow its module)
__getattr__, __dir__, __all__ = attach_stub(__name__, __file__)
