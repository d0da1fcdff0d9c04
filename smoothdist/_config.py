"""Numba compilation policy, in one place.

Every kernel in this package is decorated through these flags; nothing else in the code base
may hard-code ``fastmath=``, ``parallel=`` or ``error_model=`` (``tests/repo/test_config_policy.py``
greps for it).

* ``FASTMATH`` is off: LogSumExp relies on IEEE ``exp`` underflow and on ``inf`` comparisons,
  which fastmath is allowed to break.
* ``CACHE`` is on, so a fresh process loads compiled kernels from ``__pycache__``.
* ``ERROR_MODEL`` is ``"numpy"``: a float division by zero gives ``inf`` / ``nan`` as in numpy
  instead of raising ``ZeroDivisionError``. Kernels trust their (validated) input and never
  divide by zero on purpose, but under numba's default ``"python"`` model every division
  carries a zero test and an exception exit, which keeps LLVM from optimising the hot loops
  around it: the same images bit for bit, and faster (performance guide, "Tuning constants").
* ``NJIT_INLINE`` (``NJIT`` with ``forceinline``) is for small helpers that hot loops call
  (the whole-mesh traversal): numba does not inline njit calls on its own; LLVM inlines them,
  but each is still a compiled library of its own. ``NJIT_IR_INLINE`` (numba's
  ``inline="always"``) merges a function into its callers before typing: no library of its
  own, for the levels between an entry kernel and its work (the traversal loop and its query
  kinds' functions, a task's body). ``NJIT_GENERIC`` is that without the cache, for the
  traversal loop that takes a query kind's functions.
* ``PARALLEL`` may be switched off with ``SMOOTHDIST_PARALLEL=0`` (serial reference runs).
  Those runs do not use the on-disk cache: numba's cache index is keyed on the signature,
  the machine and the bytecode, not on ``parallel=``, so they would load the parallel
  kernels compiled by an earlier run (and store serial ones that a later parallel run
  would load).
"""

import os

FASTMATH = False
ERROR_MODEL = "numpy"
PARALLEL = os.environ.get("SMOOTHDIST_PARALLEL", "1") != "0"
CACHE = PARALLEL

#: keyword arguments for small scalar kernels called from other kernels
NJIT = dict(cache=CACHE, fastmath=FASTMATH, nogil=True, error_model=ERROR_MODEL)
#: keyword arguments for batch kernels that loop over queries with ``prange``
NJIT_PARALLEL = dict(cache=CACHE, fastmath=FASTMATH, nogil=True, parallel=PARALLEL,
                     error_model=ERROR_MODEL)
#: keyword arguments for small helpers of hot loops: ``NJIT`` plus ``forceinline`` (LLVM's
#: ``alwaysinline``: no call, and a caller's constant arguments fold into the helper)
NJIT_INLINE = dict(NJIT, forceinline=True)
#: ``NJIT`` with numba's own inlining (``inline="always"``): the function's code is merged into
#: each caller before typing, so it has no compiled library of its own. For the levels between
#: an entry kernel and the code it runs (the whole-mesh traversal, the loop): numba optimises
#: and generates machine code for everything a library links in, again in every library up the
#: call chain, so each level costs the first call as much compile time as all it calls
#: (performance guide, "Cold start").
NJIT_IR_INLINE = dict(NJIT, inline="always")
#: ``NJIT_IR_INLINE`` without the on-disk cache, for the generic traversal functions
#: (``smoothdist._kernels.traversal``) that take other functions and any query type as
#: arguments: a cached entry would name the caller's types, and another process that cannot
#: import the caller's module (a test, a notebook) would fail to read the cache index. They are
#: always inlined into cached kernels, whose cache holds them.
NJIT_GENERIC = dict(NJIT_IR_INLINE, cache=False)
