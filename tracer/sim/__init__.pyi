"""tracer.sim's public names, each from the module that defines it: the one list of them
(``tracer/sim/__init__.py`` imports each on first use, so that scipy loads only when needed;
editors read this file to go to each definition). The movie writer is
``tracer.sim.animate.animate`` (not exported here: it would shadow its module)."""

from tracer.sim.run import simulate as simulate
from tracer.sim.simfile import load_simulation as load_simulation
from tracer.sim.simulation import Simulation as Simulation

__all__ = ["Simulation", "load_simulation", "simulate"]
