"""The paper's parameter studies (Madan & Levin 2022), as packages of independent tasks.

One module per study, each a sub-command of :mod:`tracer.cli` (``HELP``,
``add_arguments(parser)`` and ``run(args)``), with the three parts every study has: a function
that lists independent, picklable tasks (small dicts), a pure function that runs one task and
returns a small record, and a reducer that writes the CSV, plots and report from the records.

* :mod:`.beta`: ``tracer ablate-beta MESH`` (Sec. 4.3, figure "betatest");
* :mod:`.alpha`: ``tracer ablate-alpha STUDY`` (the alpha figures of Sec. 3);
* :mod:`.grid`: ``tracer bench-grid DIR`` (the Thingi10K grid benchmark of Sec. 4.4);
* :mod:`.bh_switch`: ``tracer bh-switch CLOUD`` (the Barnes-Hut switch study of Sec. 4.3);
* :mod:`.plots`: their plots and reports; :mod:`.common`: shared helpers.

The tasks run through :mod:`tracer.runner` (in-process, on a local Dask cluster or on an
existing one, with a per-task results file (resume), retries and a progress bar), which the
frames of ``tracer simulate`` use as well. Every command writes through temporary files
(:func:`tracer.outputs.atomic_write`), refuses to replace earlier results without
``--overwrite``, and records each task's row as soon as it arrives, so that an interruption
(Ctrl-C) keeps the completed rows and ``--resume`` carries on from them. matplotlib (Agg) and
dask are imported only where they are used.
"""
