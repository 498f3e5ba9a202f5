"""``bench/estimator_replay.py``: a recording keeps the world's drive terms, and the replay
reports how well the filter learnt them (per family, hyphenated family names included)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest


@pytest.fixture
def replay(bench_script: Callable[[str], ModuleType]) -> ModuleType:
    return bench_script("estimator_replay")


def test_a_recording_keeps_the_drive_and_the_replay_compares_the_learnt_calibration(
        tmp_path: Path, replay: ModuleType, bench_script: Callable[[str], ModuleType]) -> None:
    path = replay._record_one(("overtaking", 0, 0, "harsh", str(tmp_path)))
    kept = np.load(path)["calibration"]
    # the same terms a world built from the same (family, seed, run, noise) drives with
    from clomp.planner import Configurator
    from clomp.runtime.experiment.runner import RunSpec, scene_for, noise_seed
    from clomp.runtime.experiment.groundtruth import make_robot

    scene, _ = scene_for(RunSpec("overtaking", 0, 0, "planning", "harsh"))
    model = Configurator().robot
    robot = make_robot(scene, noise="harsh", seed=noise_seed(0, 0), model=model)
    expected = bench_script("estimate_ceiling").true_calibration(robot, model.wheel_base)
    assert np.allclose(kept, expected) and abs(kept[2]) > 0.0
    name, position, heading, cpu, learnt, truth = replay._replay(path, {})
    assert name.startswith("overtaking-0-0-harsh") and position >= 0.0 and heading >= 0.0
    assert len(learnt) == 4 and truth is not None and np.allclose(truth, expected)
    assert "curvature sign right in" in replay.calibration_line([(name, position, heading, cpu, learnt, truth)])


def test_family_names_with_hyphens_and_the_sign_count(replay: ModuleType) -> None:
    assert replay.family_of("cul-de-sac-3-12-harsh.npz") == "cul-de-sac"
    assert replay.family_of("u-trap-0-1-paper.npz") == "u-trap"
    assert replay.family_of("slalom-0-9-harsh.npz") == "slalom"
    world = (-0.05, -0.05, 0.3, 0.0)
    small = (0.0, 0.0, 0.01, 0.0)  # too small a curvature to count its sign
    rows = [("f", 0.0, 0.0, 0.0, (0.0, 0.0, c, 0.0), world) for c in (0.2, 0.1, -0.1)]
    rows.append(("f", 0.0, 0.0, 0.0, (0.0, 0.0, -0.3, 0.0), small))
    assert "sign right in 2/3 runs" in replay.calibration_line(rows)
    old = [("f", 0.0, 0.0, 0.0, (0.0,) * 4, None)]
    assert "not recorded" in replay.calibration_line(old)


def test_a_short_recording_holds_the_whole_run_and_replays_to_the_same_estimate(tmp_path: Path, replay: ModuleType) -> None:
    """``record`` keeps every call the supervisor makes to its estimator, with the keywords it
    passes now (the gyro's ``rotation``, the odometry's ``covariance``): a recorder that
    rejected one held only the reset and its run ended HALTED at once. Replayed with the same
    settings, the inputs lead to the very estimate the recording's estimator ended at."""
    path = replay.record("overtaking", 0, 0, "harsh", str(tmp_path), max_time=6.0)
    d = np.load(path)
    kinds = list(d["kinds"])
    assert "Error" not in str(d["reason"]), d["reason"]  # ended by the time limit, not by a failing call
    assert kinds.count(replay.RESET) == 1 and kinds.count(replay.UPDATE) >= 20  # ~5.5 revolutions/s for 6 s
    assert kinds.count(replay.ADVANCE) >= 50  # one a control tick (0.1 s)
    advances = d["scalars"][d["kinds"] == replay.ADVANCE]
    assert not np.isnan(advances[:, 3]).any()  # the world's gyro: its heading kept with every advance
    assert kinds.count(replay.SHOCK) >= 50  # and its accelerometer's peak, a tick
    odo, _cpu = replay.replay_estimator(path, {})
    assert odo.pose.as_list() == list(d["estimate"])  # the same inputs, the same estimate, bit for bit
