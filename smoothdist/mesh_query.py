"""Deprecated: moved to :mod:`smoothdist._kernels.mesh_query` (this path warns on import)."""
from smoothdist._moved import forward
__getattr__, __dir__ = forward(__name__, "smoothdist._kernels.mesh_query")
