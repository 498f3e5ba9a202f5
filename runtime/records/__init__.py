"""Records of runs: the JSON-lines run log (:mod:`.runlog`), LaserScan topics of ROS bags
(:mod:`.bags`) and run logs as MCAP (:mod:`.mcap_writer`).

May import: formal, planner, numpy; nothing else of the runtime.

>>> from clomp.runtime.records import RunLog, read_log
"""

from clomp.runtime.records.bags import BagError, LaserScan, LaserScanTopic, bag_topics, read_laserscans
from clomp.runtime.records.mcap_writer import ConvertError, write_mcap
from clomp.runtime.records.runlog import LogError, RunLog, RunLogLike, plan_fields, read_log, scans_from_log

__all__ = [
    "BagError", "ConvertError", "LaserScan", "LaserScanTopic", "LogError", "RunLog", "RunLogLike",
    "bag_topics", "plan_fields", "read_laserscans", "read_log", "scans_from_log", "write_mcap",
]
