"""``python -m tracer``: see :mod:`tracer.cli`."""

import sys

try:
    from tracer.cli import main
except KeyboardInterrupt:  # Ctrl-C while the modules load
    sys.stderr.write("interrupted: stopped before anything was written\n")
    sys.exit(130)

sys.exit(main())
