"""Estimation: where the robot is, from what its LiDAR sees.

``clomp.runtime.estimation.icp`` matches two scans (point-to-line ICP with a dead-reckoning
prior, gating and degeneracy detection); ``clomp.runtime.estimation.odometry`` fuses those
matches with dead reckoning into the pose the supervisor's tasks run on;
``clomp.runtime.estimation.doubt`` keeps what that pose may not be vouched for after a shock
the IMU felt or a revolution that saw past the map (``clomp.runtime.estimation.seethrough``:
judged also against the bearings that could show a push-sized displacement; and its mirror,
a revolution seeing surfaces nearer than the map that fits a pose elsewhere far better), and
``clomp.runtime.estimation.relocalise`` re-localises the robot after a shock against the
map drawn before it; ``clomp.runtime.estimation.standing`` sees a robot moved while it
stood building the map's seed.
"""

from __future__ import annotations

from clomp.runtime.estimation.fusion import bin_ranges
from clomp.runtime.estimation.icp import ReferenceScan, ScanMatch, direction_name, match_scans, neighbour_lines

__all__ = ["ReferenceScan", "ScanMatch", "bin_ranges", "direction_name", "match_scans", "neighbour_lines"]
