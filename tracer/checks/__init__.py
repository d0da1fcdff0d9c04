"""The image checks room: comparing renders.

Image differences (:mod:`~tracer.checks.imagediff`, ``tracer diff``), comparisons with the
authors' references (:mod:`~tracer.checks.compare`, ``tracer compare``) and notebook display
(:mod:`~tracer.checks.notebook`). The pytest fixture built on them stays at
:mod:`tracer.pytest_plugin`, the path users register. Nothing is imported here.
"""
