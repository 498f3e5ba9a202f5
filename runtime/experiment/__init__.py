"""The paper's experiment: layouts, conditions (planning, the reactive baseline), runner, plots.

- :mod:`.runner` — one run, many runs, the summary table and statistics;
- :mod:`.reactive` — the reactive baseline controller;
- :mod:`.plots` — pictures of executed runs.

May import: everything below it (formal, planner, robots, supervision, records, clock).
Import the modules themselves or the lazy names of :mod:`runtime`.
"""

__all__: list[str] = []
