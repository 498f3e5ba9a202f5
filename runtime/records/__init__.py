"""Records of runs: the JSON-lines run log (:mod:`.runlog`) and readers of recorded data.

May import: formal, planner, numpy; nothing else of the runtime.

>>> from runtime.records import RunLog, read_log
"""

from runtime.records.runlog import LogError, RunLog, RunLogLike, read_log, scans_from_log

__all__ = ["LogError", "RunLog", "RunLogLike", "read_log", "scans_from_log"]
