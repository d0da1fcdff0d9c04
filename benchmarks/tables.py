"""The markdown tables that docs/guide/performance.md quotes, made from the results files.

``tests/test_docs_tables.py`` checks that the guide holds each table exactly as this script
makes it from the committed results files, so a rerun that changes a figure cannot leave the
page behind.

Usage::

    python benchmarks/tables.py scaling benchmarks/data/scaling.json
    python benchmarks/tables.py gpu benchmarks/data/gpu_h100.json
"""

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def _load(path):
    return json.loads(Path(path).read_text(encoding="utf-8"))


def scaling_table(path):
    """The thread-scaling table of a ``bench_scaling.py`` results file: per kind, the best
    ``--stats`` seconds at each thread count, the speedup at the most threads (``--stats``
    seconds and the whole frame with its PNG) and Amdahl's law fitted to all counts."""
    d = _load(path)
    m = d["machine"]
    counts = [str(n) for n in d["threads"]]
    top = counts[-1]
    lines = [f"{m['cpu']}, {m['cores']} cores, {d['size'][0]}x{d['size'][1]}, best of "
             f"{d['repeat']}, {d['date']} (Python {m['python']}, numpy {m['numpy']}, numba "
             f"{m['numba']})",
             "",
             "| kind | " + " | ".join(f"{n} thr. s" for n in counts)
             + f" | speedup at {top} | frame speedup at {top} | serial s (Amdahl) "
               f"| efficiency at {top} | load average |",
             "|---" * (len(counts) + 6) + "|"]
    for kind, k in d["kinds"].items():
        sec, frame = k["seconds"], k["frame"]
        eff = sec["best"]["1"] / (int(top) * sec["best"][top])
        serial = sec.get("serial_all", sec["serial_1_2"])
        lo, hi = k["load_average"]
        lines.append(f"| {kind} | " + " | ".join(f"{sec['best'][n]:.3f}" for n in counts)
                     + f" | {sec['speedup'][top]:.2f} | {frame['speedup'][top]:.2f} "
                       f"| {serial:.3f} | {eff:.2f} | {lo:.1f}-{hi:.1f} |")
    return "\n".join(lines)


def gpu_table(path):
    """The table of a ``bench_gpu.py`` results file (its own markdown, made again)."""
    from benchmarks.bench_gpu import markdown

    d = _load(path)
    return markdown(d["card"], d["rows"], d["threads"], d["cpu"])


TABLES = {"scaling": scaling_table, "gpu": gpu_table}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("kind", choices=sorted(TABLES))
    p.add_argument("path")
    args = p.parse_args(argv)
    print(TABLES[args.kind](args.path))
    return 0


if __name__ == "__main__":
    sys.exit(main())
