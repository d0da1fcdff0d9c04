"""Bounding volume hierarchy over a mixed primitive table, stored as flat arrays.

The tree is a :class:`TreeData` named tuple of numpy arrays (structure of arrays), which numba
kernels receive whole. Primitives of all three kinds live in one table, reordered so that every
node covers a contiguous range ``start[node] : start[node] + count[node]``.

Build: top-down, iterative. A node's primitives are sorted along the longest axis of their
centroids' bounding box and split where the surface area heuristic is smallest (each side
keeps at least :data:`SAH_MIN` of them, so the depth stays below about ``7.5 ln m``; the
traversal stacks hold ``depth + 4`` entries). Measured against the object-median split of
before (512^2 bunny renders at beta 0.5, V / E / F): 18 / 22 / 31 % fewer leaves visited and
17-31 % less time, at the same error against beta 0 (docs/guide/performance.md).
"""

import ctypes
import sys
import threading
import time
from typing import NamedTuple

import numba
import numpy as np

from smoothdist._config import NJIT, NJIT_GENERIC, NJIT_IR_INLINE, PARALLEL
from smoothdist._kernels.spacing import area_weights
from smoothdist.junctions import check_weights, junction_table
from smoothdist.mesh import KIND_EDGE, KIND_POINT, KIND_TRIANGLE
from smoothdist.schedule import run_largest_first


class TreeData(NamedTuple):
    """Flat BVH plus primitive table; every array is C-contiguous.

    Node arrays, ``n`` nodes (node 0 is the root):

    lo, hi : (n, 3) float64
        Bounding box of every vertex of every primitive below the node.
    left, right : (n,) int64
        Children, ``-1`` for a leaf.
    start, count : (n,) int64
        The node's primitive range in the reordered table.
    diag : (n,) float64
        Box diagonal length ``|hi - lo|`` (the Barnes-Hut "diameter" of the node).
    whi : (n,) float64
        Largest raw weight ``A w~`` (before attenuation) of any primitive below the node (>= 1):
        the Barnes-Hut far field uses ``count * whi**S`` so that it bounds every replaced term.
    lwhi : (n,) float64
        ``log(whi)`` (so that the far field ``count * whi**S * exp(-alpha d)`` costs one
        exponential).

    Primitive arrays, ``m`` primitives, in tree order:

    kind : (m,) int64
        0 point, 1 edge, 2 triangle.
    pts : (m, 9) float64
        Vertex coordinates ``x0 y0 z0 x1 y1 z1 x2 y2 z2`` (unused slots are 0).
    wc : (k, 13) float64
        Coefficients of the raw weight polynomials ``A w~`` (the paper's ``w~`` scaled by the
        mesh's ``A``; edges use the first 5), one row per class of valences: the few distinct
        polynomials of the mesh (:meth:`~smoothdist.DataMesh.weight_classes`; one row of zeros
        for a point cloud).
    wcls : (m,) int64
        The row of ``wc`` that is each primitive's weight polynomial (points: 0, unused). A
        primitive's coefficients are ``wc[wcls[i]]``: 8 bytes a primitive instead of 104.
    pwhi : (m,) float64
        Upper clamp of the primitive's raw weight ``A w~`` (the lower clamp is 1).
    orig : (m,) int64
        Index of the primitive in the mesh's own numbering: points, then edges, then triangles.

    Scalars:

    A : float
        The valence bound of the mesh (paper's ``A``), already folded into ``wc``; kept for
        reference only, so that trees of different meshes can be concatenated.
    depth : int
        Depth of the tree (root = 0).
    """

    lo: np.ndarray
    hi: np.ndarray
    left: np.ndarray
    right: np.ndarray
    start: np.ndarray
    count: np.ndarray
    diag: np.ndarray
    whi: np.ndarray
    lwhi: np.ndarray
    kind: np.ndarray
    pts: np.ndarray
    wc: np.ndarray
    wcls: np.ndarray
    pwhi: np.ndarray
    orig: np.ndarray
    A: float
    depth: int


def primitive_table(mesh, order=None, paper_weights=True):
    """Gather ``(kind, pts, wc, wcls, pwhi, A)`` for every primitive of a
    :class:`~smoothdist.DataMesh`, in the mesh's own numbering (points, edges, triangles) or,
    given ``order (m,)`` int64, in that order (row ``k`` is primitive ``order[k]``): the tree's
    table is written once, in tree order, with no copy in the mesh's order before it.

    ``wc (k, 13)`` holds the coefficients of the mesh's raw weights ``A w~`` (``A`` folded
    in), one row per weight class (:meth:`~smoothdist.DataMesh.weight_classes`: the edges'
    classes first, then the triangles'; a point cloud has one row of zeros), and ``wcls (m,)``
    each primitive's row. Without ``paper_weights`` the weight classes are not computed (the
    caller puts another scheme in, :func:`tree_with_weights`): one row of zeros, ``A = 1``.
    """
    V = mesh.V
    P, E, T = mesh.points, mesh.edges, mesh.triangles
    m = P.size + E.shape[0] + T.shape[0]
    if order is None:
        order = np.arange(m, dtype=np.int64)
    kind = np.empty(m, dtype=np.int64)
    pts = np.zeros((m, 9))
    wcls = np.zeros(m, dtype=np.int64)
    pwhi = np.ones(m)
    if not paper_weights:
        for _ in _gather(V, P, E, T, order, kind, pts):
            pass
        return kind, pts, np.zeros((1, 13)), wcls, pwhi, 1.0
    w = mesh.weight_classes()
    A = w.A
    ke = w.edge_coeffs.shape[0]
    wc = np.zeros((max(1, ke + w.tri_coeffs.shape[0]), 13))
    wc[:ke, :5] = A * w.edge_coeffs
    wc[ke:ke + w.tri_coeffs.shape[0]] = A * w.tri_coeffs
    for code, at, i in _gather(V, P, E, T, order, kind, pts):
        if code == KIND_EDGE:
            wcls[at] = w.edge_class[i]
            pwhi[at] = w.edge_whi[w.edge_class[i]]
        elif code == KIND_TRIANGLE:
            wcls[at] = ke + w.tri_class[i]
            pwhi[at] = w.tri_whi[w.tri_class[i]]
    return kind, pts, wc, wcls, pwhi, A


def _gather(V, P, E, T, order, kind, pts):
    """Write :func:`primitive_table`'s ``kind`` and ``pts`` in ``order``, one kind at a time,
    yielding ``(code, at, i)`` after each: the kind, its rows of the table, and their indices
    among that kind's primitives."""
    p, e = P.size, E.shape[0]
    m = kind.size
    for code, first, rows in ((KIND_POINT, 0, P[:, None]), (KIND_EDGE, p, E),
                              (KIND_TRIANGLE, p + e, T)):
        if rows.shape[0] == 0:
            continue
        if rows.shape[0] == m:                  # one kind: every row, no selection
            at, i = slice(None), order
        else:
            at = np.flatnonzero((order >= first) & (order < first + rows.shape[0]))
            i = order[at] - first
        kind[at] = code
        for j in range(rows.shape[1]):
            pts[at, 3 * j:3 * j + 3] = V[rows[i, j]]
        yield code, at, i


def primitive_boxes(mesh):
    """``(cent, plo, phi)``, each ``(m, 3)`` float64: every primitive's centroid and bounding
    box, in the mesh's own numbering (points, edges, triangles)."""
    V = mesh.V
    parts = [([V[mesh.points]]) if mesh.points.size else None,
             [V[mesh.edges[:, j]] for j in range(2)] if mesh.edges.size else None,
             [V[mesh.triangles[:, j]] for j in range(3)] if mesh.triangles.size else None]
    parts = [X for X in parts if X is not None]
    if len(parts) == 1 and len(parts[0]) == 1:   # a point cloud: a point is its own box
        c = np.ascontiguousarray(parts[0][0])
        return c, c, c
    cent, plo, phi = [], [], []
    for X in parts:
        s = X[0].copy()
        for Xj in X[1:]:
            s += Xj
        s /= len(X)
        cent.append(s)
        plo.append(np.minimum.reduce(X) if len(X) > 1 else X[0])
        phi.append(np.maximum.reduce(X) if len(X) > 1 else X[0])
        del X
    if len(cent) == 1:
        return cent[0], plo[0], phi[0]
    return np.concatenate(cent), np.concatenate(plo), np.concatenate(phi)


def build_tree(mesh, leaf_size=1, progress=None, weights="paper"):
    """Build the :class:`TreeData` of a :class:`~smoothdist.DataMesh`.

    Parameters
    ----------
    mesh : DataMesh
    leaf_size : int
        Largest number of primitives in a leaf (>= 1).
    progress : callable(done, total, elapsed_s), optional
        Called about twice a second while the tree is built (``done`` primitives of
        ``total`` placed in leaves), and once at the end.
    weights : str
        The weight scheme (:func:`tree_with_weights`): another than ``"paper"`` is put in
        directly, without computing the paper's weight classes first (0.37 s at 1M triangles).

    Memory: the primitive table, ``(9 + 4) x 8`` bytes per primitive, written once in tree
    order (the weight polynomials are a few rows that the primitives index), plus 104 bytes
    per node (at most ``2 m - 1`` nodes); during the build the primitives' centroids and
    boxes, 72 bytes per primitive (24 for a point cloud).
    """
    cent, plo, phi = primitive_boxes(mesh)
    m = cent.shape[0]
    done = np.zeros(numba.get_num_threads() + 1, dtype=np.int64)
    if progress is None:
        built = _run_build(cent, plo, phi, int(leaf_size), done)
    else:
        # the kernel releases the GIL (nogil): run it in a thread and poll its counter
        box = []
        worker = threading.Thread(target=lambda: box.append(_run_build(cent, plo, phi,
                                                                       int(leaf_size), done)))
        t0 = time.perf_counter()
        worker.start()
        while worker.is_alive():
            worker.join(0.5)
            if worker.is_alive():
                progress(int(done.sum()), m, time.perf_counter() - t0)
        progress(int(done.sum()), m, time.perf_counter() - t0)
        if not box:
            raise RuntimeError("BVH build failed")
        built = box[0]
    del cent, plo, phi
    order, lo, hi, left, right, start, count, depth = built
    del built
    release_freed_memory()          # the boxes and the build's scratch: back to the system
    diag = np.sqrt(((hi - lo) ** 2).sum(axis=1))
    paper = check_weights(weights) == "paper"
    kind, pts, wc, wcls, pwhi, A = primitive_table(mesh, order, paper)
    points_only = mesh.edges.shape[0] == 0 and mesh.triangles.shape[0] == 0
    whi = np.ones(lo.shape[0]) if points_only or not paper else _node_max(pwhi, start, count)
    tree = TreeData(lo=lo, hi=hi, left=left, right=right, start=start, count=count, diag=diag,
                    whi=whi, lwhi=np.log(whi), kind=kind, pts=pts, wc=wc, wcls=wcls, pwhi=pwhi,
                    orig=order, A=float(A), depth=int(depth))
    return tree if paper else tree_with_weights(tree, mesh, weights)


#: trees of at least this many primitives are built on several threads (below it a thread's
#: start costs more than it saves)
PARALLEL_BUILD_MIN = 1 << 15
#: ... in about this many subtrees per thread, handed out largest first
BUILD_TASKS_PER_THREAD = 4


def _run_build(cent, plo, phi, leaf_size, done, threads=None, parallel_min=None):
    """``(order, lo, hi, left, right, start, count, depth)`` of the tree over the primitives'
    centroids ``cent`` and boxes ``plo, phi``; ``done (k,)`` int64 counts the primitives placed
    (summed over its entries: one per thread of the build, each written by its own thread).

    On ``threads`` threads (default numba's, 1 under ``SMOOTHDIST_PARALLEL=0``) when there are
    at least ``parallel_min`` primitives (default :data:`PARALLEL_BUILD_MIN`): the top of the
    tree is split one level at a time, the nodes of a level side by side, down to nodes of at
    most ``m / (threads x`` :data:`BUILD_TASKS_PER_THREAD` ``)`` primitives, whose subtrees
    are then built side by side, each into rows of its own: numbered as the serial build
    numbers them (leaf size 1: a subtree's node count is known in advance) or renumbered so
    afterwards (larger leaves). The tree is the serial build's, bit for bit, whatever the
    thread count.
    """
    m = cent.shape[0]
    threads = threads or (numba.get_num_threads() if PARALLEL else 1)
    threads = max(1, min(threads, done.size - 1))      # a progress counter each
    parallel_min = PARALLEL_BUILD_MIN if parallel_min is None else parallel_min
    # every leaf holds a primitive or more, so a binary tree has at most 2 m - 1 nodes. The
    # arrays are made here, so that the kernel compiles none of numpy's constructors (a
    # cold-start cost)
    cap = max(1, 2 * m)
    order = np.arange(m, dtype=np.int64)
    nodes = (np.empty((cap, 3)), np.empty((cap, 3)), np.full(cap, -1, dtype=np.int64),
             np.full(cap, -1, dtype=np.int64), np.zeros(cap, dtype=np.int64),
             np.zeros(cap, dtype=np.int64))
    scratch = (np.empty(m), np.empty(m), np.empty(m, dtype=np.int64))

    def build(slot, node, s, e, d, first, defer):
        """One call of the kernel: ``(next free number, depth, deferred nodes)``."""
        front = np.empty((2, 5), dtype=np.int64)
        kernel = _build_long if m >= RADIX_BUILD_MIN else _build
        nxt, depth, n_front = kernel(cent, plo, phi, leaf_size, done[slot:slot + 1], order,
                                     *nodes, *scratch,
                                     np.empty((5, RADIX_BUCKETS), dtype=np.int64), node, s, e,
                                     d, first, defer, front)
        return nxt, depth, [tuple(int(v) for v in front[j]) for j in range(n_front)]

    if threads == 1 or m < max(parallel_min, 2):
        n_nodes, depth, _ = build(0, 0, 0, m, 0, 1, 0)
        return (order,) + _trimmed(nodes, n_nodes, cap) + (depth,)
    small = max(leaf_size, m // (threads * BUILD_TASKS_PER_THREAD))
    serial = leaf_size == 1       # the subtrees' numbers are the serial build's already
    free = [1]                    # larger leaves: the next number not handed out yet

    def numbered(entry):
        """``entry`` with the number its call starts from: given by its parent's call (leaf
        size 1), else the next free ones (a split names 2 children; a subtree of k
        primitives has at most 2 k - 2 nodes below its root)."""
        node, s, e, d, first = entry
        if first < 0:
            first = free[0]
            free[0] += 2 if e - s > small else 2 * (e - s) - 2
        return node, s, e, d, first

    results, tasks = [], []
    level = [(0, 0, m, 0, 1 if serial else -1)]
    while level:
        level = [numbered(x) for x in level]
        tasks += [x for x in level if x[2] - x[1] <= small]
        big = [x for x in level if x[2] - x[1] > small]
        level = []

        def split(i, slot, big=big, level=level):
            node, s, e, d, first = big[i]
            nxt, depth, children = build(slot, node, s, e, d, first, e - s - 1)
            results.append((nxt, depth))
            level.extend(children)

        run_largest_first(split, range(len(big)), threads)

    def subtree(i, slot):
        results.append(build(slot, *tasks[i], 0)[:2])

    run_largest_first(subtree, np.argsort([s - e for _, s, e, _, _ in tasks], kind="stable"),
                   threads)
    depth = max(r[1] for r in results)
    if serial:
        return (order,) + _trimmed(nodes, max(r[0] for r in results), cap) + (depth,)
    return (order,) + _serial_numbering(*nodes) + (depth,)


def _trimmed(nodes, n_nodes, cap):
    """The node arrays cut to ``n_nodes`` rows: a leaf-size-1 tree fills 2 m - 1 of the 2 m
    rows, and keeps its arrays (no copy, no second peak); a sparser one is copied to its size
    (np.empty's untouched rows cost no memory)."""
    if 2 * n_nodes > cap:
        return tuple(a[:n_nodes] for a in nodes)
    return tuple(a[:n_nodes].copy() for a in nodes)


def _serial_numbering(lo, hi, left, right, start, count):
    """The node arrays renumbered in place as the serial build numbers them (children of the
    ``k``-th inner node in preorder, left subtree first, are ``2 k + 1`` and ``2 k + 2``), and
    returned trimmed to the tree's nodes (views): rows not reached from the root (a task's
    unused ones) are dropped. One array at a time, so the extra memory is one array's."""
    new_of = _preorder_ids(left, right)
    reached = np.flatnonzero(new_of >= 0)
    n = reached.size
    old = np.empty(n, dtype=np.int64)
    old[new_of[reached]] = reached
    del reached
    for a in (lo, hi, start, count):
        a[:n] = a[old]
    for child in (left, right):
        c = child[old]
        inner = c >= 0
        c[inner] = new_of[c[inner]]
        child[:n] = c
    return tuple(a[:n] for a in (lo, hi, left, right, start, count))


@numba.njit(**NJIT)
def _preorder_ids(left, right):
    """``(rows,)`` int64: each node's number in the serial build's order (see
    :func:`_serial_numbering`), ``-1`` for rows not in the tree."""
    new_of = np.full(left.size, -1, dtype=np.int64)
    stack = np.empty(left.size + 1, dtype=np.int64)
    stack[0] = 0
    sp = 1
    new_of[0] = 0
    k = 0
    while sp > 0:
        sp -= 1
        node = stack[sp]
        if left[node] < 0:
            continue
        new_of[left[node]] = 2 * k + 1
        new_of[right[node]] = 2 * k + 2
        k += 1
        stack[sp] = right[node]
        stack[sp + 1] = left[node]
        sp += 2
    return new_of


def release_freed_memory():
    """Hand the memory freed so far back to the operating system (glibc's ``malloc_trim``;
    nothing elsewhere). glibc raises its threshold for serving large arrays from their own
    mappings after the first such array is freed, so the build's transients (hundreds of MB
    for a million triangles) would otherwise stay in the process's heap, and in its resident
    size, after the build: a second field built later reuses them, other programs cannot."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another C library, another system)."""
    if "trim" not in _LIBC:
        _LIBC["trim"] = None
        if sys.platform.startswith("linux"):
            try:
                _LIBC["trim"] = ctypes.CDLL("libc.so.6").malloc_trim
            except (OSError, AttributeError):
                pass
    return _LIBC["trim"]


_LIBC = {}


#: an empty box ``(lo0, lo1, lo2, hi0, hi1, hi2)``
_EMPTY_BOX = (np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf)


@numba.njit(**NJIT_IR_INLINE)
def _grow(box, plo, phi, i):
    """``box`` grown to hold the box ``plo[i], phi[i]``."""
    return (min(box[0], plo[i, 0]), min(box[1], plo[i, 1]), min(box[2], plo[i, 2]),
            max(box[3], phi[i, 0]), max(box[4], phi[i, 1]), max(box[5], phi[i, 2]))


@numba.njit(**NJIT_IR_INLINE)
def _half_area(box):
    """Half the surface area of ``box``."""
    a = box[3] - box[0]
    b = box[4] - box[1]
    c = box[5] - box[2]
    return a * b + b * c + c * a


@numba.njit(**NJIT)
def _build(cent, plo, phi, leaf_size, done, order, lo, hi, left, right, start, count, keys,
           kbuf, obuf, stacks, root, s0, e0, d0, next_node, defer, frontier):
    """:func:`_build_with` sorting by :func:`_sort_short` (merge sort only): for trees of
    fewer than :data:`RADIX_BUILD_MIN` primitives, whose first build (a fresh install's first
    call) then compiles no radix sort."""
    return _build_with(_sort_short, cent, plo, phi, leaf_size, done, order, lo, hi, left,
                       right, start, count, keys, kbuf, obuf, stacks, root, s0, e0, d0,
                       next_node, defer, frontier)


@numba.njit(**NJIT)
def _build_long(cent, plo, phi, leaf_size, done, order, lo, hi, left, right, start, count,
                keys, kbuf, obuf, stacks, root, s0, e0, d0, next_node, defer, frontier):
    """:func:`_build_with` sorting long ranges by radix (:func:`_sort_order`): for trees of
    :data:`RADIX_BUILD_MIN` primitives or more."""
    return _build_with(_sort_order, cent, plo, phi, leaf_size, done, order, lo, hi, left,
                       right, start, count, keys, kbuf, obuf, stacks, root, s0, e0, d0,
                       next_node, defer, frontier)


@numba.njit(**NJIT_GENERIC)
def _build_with(sort, cent, plo, phi, leaf_size, done, order, lo, hi, left, right, start,
                count, keys, kbuf, obuf, stacks, root, s0, e0, d0, next_node, defer,
                frontier):
    """Build the subtree of node ``root``, the primitives ``order[s0:e0]`` at depth ``d0``,
    into the given arrays (``order`` starts as ``0..m-1``; node arrays hold at least the
    number of nodes; ``keys, kbuf, obuf (m,)`` and ``stacks (5, RADIX_BUCKETS)`` are scratch;
    new nodes
    are numbered from ``next_node`` on). A node of more than ``leaf_size`` and at most
    ``defer`` primitives is not split but listed in ``frontier`` as ``(node, s, e, depth,
    first)``, for a later call (``defer = 0``: none): with ``leaf_size = 1`` its subtree's
    size is known (``2 (e - s) - 1`` nodes) and ``first`` is the number the serial build
    gives its first child, the numbers up to its last node skipped here; ``-1`` otherwise.
    Returns ``(next free node number, depth, number
    of nodes listed)``."""
    st_node = stacks[0]
    st_s = stacks[1]
    st_e = stacks[2]
    st_d = stacks[3]
    st_node[0] = root
    st_s[0] = s0
    st_e[0] = e0
    st_d[0] = d0
    sp = 1
    n_nodes = next_node
    depth = d0
    n_front = 0
    while sp > 0:
        sp -= 1
        node = st_node[sp]
        s = st_s[sp]
        e = st_e[sp]
        d = st_d[sp]
        if leaf_size < e - s <= defer:
            frontier[n_front, 0] = node
            frontier[n_front, 1] = s
            frontier[n_front, 2] = e
            frontier[n_front, 3] = d
            frontier[n_front, 4] = -1
            if leaf_size == 1:
                # its subtree has e - s - 1 inner nodes, whose children the serial build
                # numbers next: skip their numbers, and the later call starts there
                frontier[n_front, 4] = n_nodes
                n_nodes += 2 * (e - s - 1)
            n_front += 1
            continue
        if d > depth:
            depth = d
        box = _EMPTY_BOX
        cbox = _EMPTY_BOX
        for k in range(s, e):
            i = order[k]
            box = _grow(box, plo, phi, i)
            cbox = _grow(cbox, cent, cent, i)
        for c in range(3):
            lo[node, c] = box[c]
            hi[node, c] = box[3 + c]
        start[node] = s
        count[node] = e - s
        if e - s <= leaf_size:
            done[0] += e - s
            continue
        ext0 = cbox[3] - cbox[0]
        ext1 = cbox[4] - cbox[1]
        ext2 = cbox[5] - cbox[2]
        axis = 0
        if ext1 > ext0 and ext1 >= ext2:
            axis = 1
        elif ext2 > ext0 and ext2 > ext1:
            axis = 2
        for k in range(s, e):
            keys[k] = cent[order[k], axis]
        sort(keys, order, kbuf, obuf, s, e, stacks[4])
        mid = _sah_split(plo, phi, order, kbuf, s, e)
        l = n_nodes
        r = n_nodes + 1
        n_nodes += 2
        left[node] = l
        right[node] = r
        st_node[sp] = r
        st_s[sp] = mid
        st_e[sp] = e
        st_d[sp] = d + 1
        sp += 1
        st_node[sp] = l
        st_s[sp] = s
        st_e[sp] = mid
        st_d[sp] = d + 1
        sp += 1
    return n_nodes, depth, n_front


#: each side of a split holds at least this fraction of the node's primitives (bounds the
#: depth by ``log(m) / log(1 / (1 - SAH_MIN))``, about 7.5 ln m)
SAH_MIN = 0.125


@numba.njit(**NJIT_IR_INLINE)
def _sah_split(plo, phi, order, area, s, e):
    """Split position ``k`` in ``(s, e)`` of ``order[s:e]`` (sorted along the split axis) that
    minimises the surface area heuristic ``A(s:k) (k - s) + A(k:e) (e - k)`` (``A``: the box
    area of those primitives, up to a factor 2), each side at least :data:`SAH_MIN` of the
    primitives. ``area (m,)``: scratch."""
    box = _EMPTY_BOX
    for k in range(s, e):
        box = _grow(box, plo, phi, order[k])
        area[k] = _half_area(box)                # the box of order[s:k+1]
    n = e - s
    k_min = s + max(1, int(SAH_MIN * n))
    k_max = e - max(1, int(SAH_MIN * n))
    best = np.inf
    arg = (s + e) // 2
    box = _EMPTY_BOX
    for k in range(e - 1, s, -1):                # the box of order[k:e]
        box = _grow(box, plo, phi, order[k])
        if k < k_min or k > k_max:
            continue
        cost = area[k - 1] * (k - s) + _half_area(box) * (e - k)
        if cost < best:
            best = cost
            arg = k
    return arg


#: ranges of at least this many keys are sorted by ``_radix_sort``, shorter ones by
#: ``_sort_by_key`` (both stable: the same order)
RADIX_MIN = 1024
#: trees of at least this many primitives are built by ``_build_long`` (its radix sort
#: pays for its compile time), smaller ones by ``_build``
RADIX_BUILD_MIN = 1 << 15
#: bits of the radix sort's digit (six passes over a 64-bit key) and its buckets
RADIX_BITS = 11
RADIX_BUCKETS = 1 << RADIX_BITS
_SIGN = np.uint64(1 << 63)
_ONES = np.uint64(0xFFFFFFFFFFFFFFFF)
_DIGIT = np.uint64(RADIX_BUCKETS - 1)


@numba.njit(**NJIT_IR_INLINE)
def _sort_short(keys, items, kbuf, ibuf, s, e, counts):
    """Sort ``items[s:e]`` by ``keys[s:e]`` stably with :func:`_sort_by_key` (nothing to do
    for keys in order already); ``counts`` unused (the signature of :func:`_sort_order`)."""
    for k in range(s + 1, e):
        if keys[k] < keys[k - 1]:
            _sort_by_key(keys, items, kbuf, ibuf, s, e)
            return


@numba.njit(**NJIT_IR_INLINE)
def _sort_order(keys, items, kbuf, ibuf, s, e, counts):
    """Sort ``items[s:e]`` by ``keys[s:e]`` (finite float64), stably; ``keys`` and the buffers
    are left as scratch. Nothing to do for keys in order already (a child split along its
    parent's axis); long ranges by :func:`_radix_sort`, short ones by :func:`_sort_by_key`."""
    for k in range(s + 1, e):
        if keys[k] < keys[k - 1]:
            break
    else:
        return
    if e - s >= RADIX_MIN:
        _radix_sort(keys, items, kbuf, ibuf, s, e, counts)
    else:
        _sort_by_key(keys, items, kbuf, ibuf, s, e)


@numba.njit(**NJIT_IR_INLINE)
def _radix_sort(keys, items, kbuf, ibuf, s, e, counts):
    """Stable LSD radix sort of ``items[s:e]`` by ``keys[s:e]`` (finite float64, ``-0.0``
    equal to ``0.0`` as in a comparison sort): the keys' bits, made to order as the numbers
    do, in :data:`RADIX_BITS`-bit digits; a digit that every key shares is skipped.
    ``counts (RADIX_BUCKETS,)`` int64 scratch; ``keys`` is left as scratch."""
    uk = keys.view(np.uint64)
    ub = kbuf.view(np.uint64)
    for k in range(s, e):
        keys[k] = keys[k] + 0.0                      # -0.0 becomes 0.0
        u = uk[k]
        uk[k] = (u ^ _ONES) if u & _SIGN else (u | _SIGN)
    n = e - s
    src_k, src_i, dst_k, dst_i = uk, items, ub, ibuf
    shift = 0
    while shift < 64:
        sh = np.uint64(shift)
        counts[:] = 0
        for k in range(s, e):
            counts[(src_k[k] >> sh) & _DIGIT] += 1
        skip = False
        for b in range(RADIX_BUCKETS):
            if counts[b] == n:
                skip = True
            if counts[b] != 0:
                break
        if not skip:
            total = s
            for b in range(RADIX_BUCKETS):
                c = counts[b]
                counts[b] = total
                total += c
            for k in range(s, e):
                b = (src_k[k] >> sh) & _DIGIT
                o = counts[b]
                counts[b] = o + 1
                dst_k[o] = src_k[k]
                dst_i[o] = src_i[k]
            src_k, src_i, dst_k, dst_i = dst_k, dst_i, src_k, src_i
        shift += RADIX_BITS
    if src_i is not items:
        for k in range(s, e):
            items[k] = src_i[k]


#: runs of this many keys are insertion-sorted before the merge passes of _sort_by_key
SORT_RUN = 16


@numba.njit(**NJIT_IR_INLINE)
def _sort_by_key(keys, items, kbuf, ibuf, s, e):
    """Sort ``keys[s:e]`` ascending and ``items[s:e]`` along, stably (equal keys keep their
    order, as ``np.argsort(kind="stable")``; keys are finite). ``kbuf``, ``ibuf``: scratch
    arrays at least as long. A bottom-up merge sort over insertion-sorted runs, written out
    here because numba's own ``argsort`` takes about a second to compile.
    """
    for r in range(s, e, SORT_RUN):
        for i in range(r + 1, min(e, r + SORT_RUN)):
            k = keys[i]
            it = items[i]
            j = i - 1
            while j >= r and keys[j] > k:
                keys[j + 1] = keys[j]
                items[j + 1] = items[j]
                j -= 1
            keys[j + 1] = k
            items[j + 1] = it
    src_k, src_i, dst_k, dst_i = keys, items, kbuf, ibuf
    width = SORT_RUN
    while width < e - s:
        for a in range(s, e, 2 * width):
            mid = min(e, a + width)
            b = min(e, a + 2 * width)
            i = a
            j = mid
            for o in range(a, b):
                if j >= b or (i < mid and not src_k[j] < src_k[i]):
                    dst_k[o] = src_k[i]
                    dst_i[o] = src_i[i]
                    i += 1
                else:
                    dst_k[o] = src_k[j]
                    dst_i[o] = src_i[j]
                    j += 1
        src_k, src_i, dst_k, dst_i = dst_k, dst_i, src_k, src_i
        width *= 2
    if src_k is not keys:
        for o in range(s, e):
            keys[o] = src_k[o]
            items[o] = src_i[o]


@numba.njit(**NJIT)
def _node_max(values, start, count):
    n = start.size
    out = np.empty(n)
    for node in range(n):
        v = values[start[node]]
        for k in range(start[node] + 1, start[node] + count[node]):
            v = max(v, values[k])
        out[node] = v
    return out


def tree_with_weights(tree, mesh, weights):
    """``tree`` (built on ``mesh``) with the weight scheme ``weights``: ``"paper"`` (the
    polynomials of :meth:`~smoothdist.DataMesh.weight_classes`, as :func:`build_tree` makes
    them) or ``"inclusion-exclusion"`` (:mod:`smoothdist.junctions`). A shallow copy: the
    nodes and corners are shared, the weight arrays (``wc``, ``wcls``, ``pwhi``, ``whi``,
    ``lwhi``, ``A``) are new."""
    if check_weights(weights) == "paper":
        _, _, wc, wcls, pwhi, A = primitive_table(mesh, tree.orig)
    else:
        wc, wcls, pwhi = junction_table(mesh, tree.kind, tree.orig)
        if mesh.points.size:        # points weighted by the area they stand for
            pwhi = np.where(tree.kind == 0, area_weights(tree), pwhi)
        A = float(pwhi.max()) if pwhi.size else 1.0
    # at least 1: a far field's distance minus log(whi) / alpha then never exceeds its box
    # distance, so the running shift stays at most the nearest distance (the clamp's d_hat <= d
    # with area weights below 1)
    whi = np.maximum(_node_max(pwhi, tree.start, tree.count), 1.0)
    return tree._replace(wc=wc, wcls=wcls, pwhi=pwhi, whi=whi, lwhi=np.log(whi), A=float(A))


def concatenate_trees(trees):
    """Merge several :class:`TreeData` into one forest.

    Returns ``(forest, roots)``: one TreeData whose node and primitive arrays are the inputs'
    concatenated (child and range indices shifted), and ``roots (k,) int64``, the node index
    of each input's root. Query it with the ``root`` argument of the point kernels. ``orig``
    keeps each input's own primitive numbering; ``A`` and ``depth`` are the maxima.
    """
    if len({t.wc.shape[1] for t in trees}) > 1:
        raise ValueError("the trees of a forest must share one weight scheme (paper or "
                         "inclusion-exclusion weights, smoothdist.junctions)")
    node_off = np.cumsum([0] + [t.lo.shape[0] for t in trees])[:-1]
    prim_off = np.cumsum([0] + [t.kind.size for t in trees])[:-1]
    class_off = np.cumsum([0] + [t.wc.shape[0] for t in trees])[:-1]

    def cat(name):
        return np.ascontiguousarray(np.concatenate([getattr(t, name) for t in trees]))

    def shifted(name, offs):
        parts = []
        for t, o in zip(trees, offs):
            a = getattr(t, name)
            parts.append(np.where(a >= 0, a + o, a) if name in ("left", "right") else a + o)
        return np.ascontiguousarray(np.concatenate(parts))

    forest = TreeData(lo=cat("lo"), hi=cat("hi"), left=shifted("left", node_off),
                      right=shifted("right", node_off), start=shifted("start", prim_off),
                      count=cat("count"), diag=cat("diag"), whi=cat("whi"), lwhi=cat("lwhi"),
                      kind=cat("kind"),
                      pts=cat("pts"), wc=cat("wc"), wcls=shifted("wcls", class_off),
                      pwhi=cat("pwhi"), orig=cat("orig"),
                      A=float(max(t.A for t in trees)), depth=int(max(t.depth for t in trees)))
    return forest, np.asarray(node_off, dtype=np.int64)
