"""The one tree traversal of the query kernels, specialised per query kind by small functions.

Every query walks a bounding-volume tree the same way: an explicit stack of ``(node, key)``
pairs, ``key`` a lower bound of the query's distance to the node's box (or its square, as the
query kind chooses); a popped node is skipped, replaced by a far field, evaluated primitive by
primitive, or opened, and its two children go on the stack with the nearer one on top. Query
kinds differ only in those decisions, so :func:`nearest_first` holds the loop and each kind
passes five ``njit`` functions (``NJIT_INLINE``, so that they compile into the loop):

``skip(tree, q, node, key, state) -> bool``
    drop a popped node (the bound already rules it out);
``approximate(tree, q, node, key, state) -> (bool, state)``
    replace the node by a far field (Barnes-Hut, ``tol``); ``True`` when it did;
``leaf(tree, q, node, state) -> (bool, state)``
    evaluate the node's primitives when it is a leaf (for the kind); ``True`` when it did;
``children(tree, q, node) -> (a, key_a, b, key_b)``
    the two children and their keys;
``keep(key, state) -> bool``
    push a child at all (branch and bound: only if nearer than the best so far).

``tree`` is whatever the kind's functions read (a ``TreeData``, an ``ExactTree``), ``q`` the
query (a tuple of scalars and arrays), ``state`` a tuple of scalars (running sums, the best so
far, counters) that the functions return updated; ``node`` an int64. numba compiles one copy of
the loop per set of functions (a function passed as an argument is part of the type), inside
the kernel that calls it, so each kernel's on-disk cache holds its own specialisation. The loop
and the generic functions here are not cached themselves (``NJIT_GENERIC``): their signatures
name the caller's types, which another process may not be able to import.

Ties (``key_a == key_b``) pop ``a`` first. Initial states hold ``int64`` counters (``ZERO``,
``NONE``), never literal ints.
"""

import numba
import numpy as np
from numba.core import types
from numba.extending import intrinsic

from smoothdist._config import NJIT_GENERIC

#: 0 and -1 as int64 for a traversal's initial state, root and node arguments. A plain ``0`` is
#: typed as the literal ``Literal[int](0)``: numba then compiles every function of the kind (and
#: all they call) once for the literal state and once more for the ``int64`` that the state
#: becomes after the first update, and a node function once per literal node (numba's compile
#: events showed the whole-mesh traversal's far field compiled twice, 32 s of a 131 s first call)
ZERO = np.int64(0)
NONE = np.int64(-1)


@intrinsic
def borrowed(typingctx, value):
    """``value`` (an array, or a tuple such as a ``TreeData`` holding arrays) with every array
    replaced by a view that carries no reference count (as a ``prange`` body sees its arrays).

    Only valid while the caller holds the original arrays (e.g. for the duration of a kernel
    call). It saves the atomic reference-count updates at every call that passes an array
    down (the tree, once per distance evaluation), about 4 % of a render's time.
    """
    def borrow(context, builder, ty, val):
        if isinstance(ty, types.Array):
            src = context.make_array(ty)(context, builder, value=val)
            dst = context.make_array(ty)(context, builder)
            context.populate_array(dst, data=src.data, shape=src.shape, strides=src.strides,
                                   itemsize=src.itemsize, meminfo=None)
            return dst._getvalue()
        if isinstance(ty, types.BaseTuple):
            for i, member in enumerate(ty):
                val = builder.insert_value(
                    val, borrow(context, builder, member, builder.extract_value(val, i)), i)
        return val

    def codegen(context, builder, signature, args):
        return borrow(context, builder, value, args[0])

    return value(value), codegen


if numba.config.DISABLE_JIT:       # NUMBA_DISABLE_JIT=1 (tests/README.md): plain Python
    def borrowed(value):           # noqa: F811
        return value


def python_function(kernel):
    """The Python function of ``kernel`` (the function itself under ``NUMBA_DISABLE_JIT=1``,
    where ``numba.njit`` returns it unchanged), to compile it again with other options."""
    return getattr(kernel, "py_func", kernel)


@numba.njit(**NJIT_GENERIC)
def nearest_first(tree, q, state, stack, dstack, root, key0, skip, approximate, leaf, children,
                  keep):
    """Traverse ``tree`` from ``root`` (key ``key0``) for query ``q``.

    ``stack (k,) int64`` and ``dstack (k,) float64`` are scratch space of the tree's stack
    length (``depth + 4``: one pending sibling per level plus both children). Returns
    ``(state, nodes)``: the final state and the number of popped nodes not skipped.
    """
    # the tree and the query as views without reference counts: the kind's functions read
    # their arrays at every node, and the caller holds them for the whole traversal
    tree = borrowed(tree)
    q = borrowed(q)
    stack[0] = root
    dstack[0] = key0
    sp = 1
    nodes = 0
    while sp > 0:
        sp -= 1
        node = stack[sp]
        key = dstack[sp]
        if skip(tree, q, node, key, state):
            continue
        nodes += 1
        done, state = approximate(tree, q, node, key, state)
        if done:
            continue
        done, state = leaf(tree, q, node, state)
        if done:
            continue
        a, ka, b, kb = children(tree, q, node)
        if ka > kb:
            a, ka, b, kb = b, kb, a, ka
        # the farther child first, so that the nearer one is popped next
        if keep(kb, state):
            stack[sp] = b
            dstack[sp] = kb
            sp += 1
        if keep(ka, state):
            stack[sp] = a
            dstack[sp] = ka
            sp += 1
    return state, nodes


@numba.njit(**NJIT_GENERIC)
def never(tree, q, node, key, state):
    """``skip`` of kinds that prune nothing on pop."""
    return False


@numba.njit(**NJIT_GENERIC)
def no_far_field(tree, q, node, key, state):
    """``approximate`` of exact kinds: no node is replaced."""
    return False, state


@numba.njit(**NJIT_GENERIC)
def always(key, state):
    """``keep`` of kinds that push both children."""
    return True


@numba.njit(**NJIT_GENERIC)
def beyond_best(tree, q, node, key, state):
    """``skip`` of branch and bound: the node is no nearer than the best so far, ``state[0]``
    (in the keys' units)."""
    return key >= state[0]


@numba.njit(**NJIT_GENERIC)
def within_best(key, state):
    """``keep`` of branch and bound: a child nearer than the best so far, ``state[0]``."""
    return key < state[0]
