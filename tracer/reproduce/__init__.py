"""``tracer reproduce`` (issue 36): every reproducible experiment of Madan & Levin 2022 and the
report of its claims.

* :mod:`.experiments`: the experiments (the studies, the grid benchmark, the Table 3
  simulations), their quick and full settings and the provenance written with each result;
* :mod:`.claims`: the paper's claims, quoted with their sections, and how each is judged;
* :mod:`.report`: ``claims.json`` and the Markdown page from a results folder;
* :mod:`.cli`: the command.
"""
