"""The paper's experiment: layouts, conditions (planning, the reactive baseline), runner, statistics, plots.

- :mod:`.layouts` — layout families, each world reproducible from (family, seed, run);
- :mod:`.reactive` — the paper's reactive baseline (one loop, one straight step of look-ahead);
- :mod:`.groundtruth` — the execution world a run uses and its ground truth (pose, contact trace);
- :mod:`.contacts` — contact episodes: collisions and brushes, counted as the paper would, and pushed contacts apart;
- :mod:`.runspec` — what one run depends on (:class:`~.runspec.RunSpec`) and its seeding;
- :mod:`.onerun` — one run of one condition, measured on the ground truth;
- :mod:`.runrecords` — one run as a pure function of its spec, a JSON-ready record; reading them back;
- :mod:`.driver` — many runs, in this process or on Dask, streamed to ``runs.jsonl`` and resumed;
- :mod:`.warmup` — the compiled kernels ready (numba's cache) before a local cluster's workers start;
- :mod:`.runner` — the names of those four in one place;
- :mod:`.stats` — Wilson and t intervals, the paired t-test, McNemar's test;
- :mod:`.results` — the CSV (documented schema), the JSON summary, the text and Markdown tables;
- :mod:`.plots` / :mod:`.report` — pictures of runs, collisions per run, success against noise, a gallery.

May import: everything below it (formal, planner, robots, supervision, records, clock); never
:mod:`clomp.runtime.cli` (the command line passes its progress bar in).
Import the modules themselves or the lazy names of :mod:`clomp.runtime`.
"""

__all__: list[str] = []
