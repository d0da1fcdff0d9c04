"""The numba kernels behind the API: private, their names may change between releases.

Small ``@njit(cache=True)`` functions over flat arrays (docs/design-notes.md has the map): closest
points and pairs, box bounds, the paper's weights, the BVH and the traversals. Users call the
validated API (:class:`smoothdist.SmoothDistanceField`, :class:`smoothdist.MeshDistance`) or, from
their own njit code, the public kernels of :mod:`smoothdist.kernels`.
"""
