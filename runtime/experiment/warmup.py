"""The compiled kernels ready before a local cluster's workers start (issue #41).

Every numba kernel of a run (the planner's, the matcher's, the ray cast's, the plan
check's) is compiled once per machine and kept in numba's cache on disk
(:func:`clomp.runtime.jit.compiled`). On an empty cache (a fresh clone, a changed kernel)
each worker process of a sweep compiled all of them itself: about 30 s of CPU per worker,
two workers compiling the same code side by side. :func:`warm_kernels` compiles them
once, in the driver, before the workers start; the workers then load them from the cache
(about 0.6 s). It does so by running a short piece of one run of each condition of the
sweep: a run compiles exactly the kernels, with exactly the argument types, that the
sweep's runs will ask for, which a hand-made list of calls would have to track.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from clomp.runtime.experiment.runrecords import run_spec
from clomp.runtime.experiment.runspec import RunSpec

__all__ = ["WARM_SECONDS", "warm_kernels"]

#: simulated seconds of the warm-up runs: enough for a plan, a few matches and plan checks
#: (measured: 10 s of one planning and one reactive overtaking run compiled every kernel
#: the same conditions' full runs at paper and harsh then loaded, none compiled again)
WARM_SECONDS = 10.0


def warm_kernels(specs: Sequence[RunSpec], seconds: float = WARM_SECONDS) -> list[str]:
    """Run the first ``seconds`` of the first run of each condition (and feedback, gyro)
    in ``specs``, here, so that the compiled kernels those runs use are in numba's cache
    before a sweep's workers start. Returns the keys of the warm-up runs. A warm-up run
    that raises is passed over (its condition's runs will say why).

    >>> warm_kernels([RunSpec("open", 0, 0, "reactive", "ideal")], seconds=1.0)
    ['open/0/0/reactive/ideal/1/1']
    """
    firsts: dict[tuple[str, str, bool, str | None], RunSpec] = {}
    for s in specs:
        firsts.setdefault((s.condition, s.feedback, s.gyro, s.policy), s)
    done = []
    for s in firsts.values():
        short = dataclasses.replace(s, max_time=min(float(s.max_time), float(seconds)))
        try:
            run_spec(short)
        except Exception:  # noqa: BLE001 - a warm-up only; the run itself reports its error
            continue
        done.append(short.key)
    return done
