"""The import graph of the packages smoothdist and tracer, read with ast (nothing imported).

Every ``import`` counts, at module level or inside a function (a deferred import is still an
arrow). ``from pkg import name`` points at the submodule ``pkg.name`` when there is one, else at
the module the package's ``__init__`` takes ``name`` from; a package's own ``__init__``
re-exports are arrows from the package down to its modules, never back up.
"""

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ("smoothdist", "tracer")


def modules(root=ROOT, packages=PACKAGES):
    """``{dotted name: file path}`` of every module of ``packages`` (packages by their
    ``__init__``)."""
    out = {}
    for pkg in packages:
        for folder, dirs, files in os.walk(os.path.join(root, pkg)):
            dirs[:] = sorted(d for d in dirs if not d.startswith((".", "__pycache__")))
            rel = os.path.relpath(folder, root).replace(os.sep, ".")
            for f in sorted(files):
                if f.endswith(".py"):
                    name = rel if f == "__init__.py" else f"{rel}.{f[:-3]}"
                    out[name] = os.path.join(folder, f)
    return out


def _imports(path, name, is_package):
    """``[(target, imported names or None)]`` of one file, relative imports resolved."""
    tree = ast.parse(open(path, encoding="utf-8").read(), path)
    here = name if is_package else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = here.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(parts + ([base] if base else []))
            out.append((base, [a.name for a in node.names]))
    return out


def graph(root=ROOT, packages=PACKAGES):
    """``{module: set of modules it imports}`` (inside ``packages`` only)."""
    mods = modules(root, packages)
    raw = {m: _imports(p, m, p.endswith("__init__.py")) for m, p in mods.items()}
    # where a package's __init__ takes each name from
    origin = {}
    for m, p in mods.items():
        if p.endswith("__init__.py"):
            for target, names in raw[m]:
                for n in names or ():
                    if target in mods and target != m:
                        origin[(m, n)] = target
    edges = {m: set() for m in mods}
    for m, imports in raw.items():
        for target, names in imports:
            if names is None:
                if target in mods:
                    edges[m].add(target)
                continue
            for n in names:
                sub = f"{target}.{n}"
                if sub in mods:
                    edges[m].add(sub)
                elif target in mods:
                    edges[m].add(origin.get((target, n), target))
        edges[m].discard(m)
    return edges


def cycles(edges):
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out
