"""Plans never pass through what the LiDAR could not see (:mod:`clomp.planner.visibility`).

Scenes of thin posts (2–6 cm square posts, 1–3 cm round chair legs) standing behind one
another are scanned by a ray-caster written here (not the planner's, not the scenarios'),
and every plan is checked with geometry of its own: the real body, inset by 3 mm, is
sampled along each task (every 5 mm of a straight, every 0.01 rad of a turn) and each
sample point must lie where a ray went: nearer than the return (or the horizon, for a beam
that returned nothing within it) of the beam on at least one side of its bearing, or inside
the body where the robot stands. Before its last task no plan's body leaves that space, and
a plan that claims the goal never does.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.planner import Configurator, PlanningError, RobotModel
from clomp.planner.visibility import KnownFree

HORIZON = 1.1
INSET = 0.003
ROBOT = RobotModel()


# -- the world: posts, and a LiDAR of its own -----------------------------------------------
def raycast(posts: list[tuple[str, float, float, float, float]], beams: int, phase: float) -> np.ndarray:
    """Per beam (bearing ``(k + phase) * 2π / beams``) the distance to the first post, inf when none."""
    a = (np.arange(beams) + phase) * (2 * math.pi / beams)
    ux, uy = np.cos(a), np.sin(a)
    best = np.full(beams, np.inf)
    for kind, cx, cy, size, turn in posts:
        if kind == "round":
            bq = ux * cx + uy * cy
            disc = bq * bq - (cx * cx + cy * cy - size * size)
            t = np.where(disc >= 0, bq - np.sqrt(np.maximum(disc, 0.0)), np.inf)
        else:  # a square of side ``size`` turned by ``turn``: slabs in its own frame
            c, s = math.cos(turn), math.sin(turn)
            ox, oy = -(cx * c + cy * s), cx * s - cy * c  # the sensor in the post's frame
            du, dv = ux * c + uy * s, uy * c - ux * s
            h = size / 2
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                t1, t2 = (-h - ox) / du, (h - ox) / du
                t3, t4 = (-h - oy) / dv, (h - oy) / dv
            near = np.maximum(np.fmin(t1, t2), np.fmin(t3, t4))
            far = np.minimum(np.fmax(t1, t2), np.fmax(t3, t4))
            t = np.where(near <= far, near, np.inf)
        best = np.minimum(best, np.where(t > 0, t, np.inf))
    return best


def returns(ranges: np.ndarray, phase: float) -> np.ndarray:
    """The scan as the planner gets it: the points within the horizon (robot frame)."""
    beams = len(ranges)
    a = (np.arange(beams) + phase) * (2 * math.pi / beams)
    ok = ranges <= HORIZON
    return np.c_[ranges[ok] * np.cos(a[ok]), ranges[ok] * np.sin(a[ok])]


def crossed(px: np.ndarray, py: np.ndarray, ranges: np.ndarray, phase: float) -> np.ndarray:
    """Per point: did a ray pass it? The beams on either side of its bearing: the point is
    nearer than one of their returns (a beam with none within the horizon went to it)."""
    beams = len(ranges)
    reach = np.minimum(ranges, HORIZON)
    step = 2 * math.pi / beams
    k = np.floor((np.arctan2(py, px) / step - phase)).astype(int) % beams
    rho = np.hypot(px, py)
    ray = (rho <= np.maximum(reach[k], reach[(k + 1) % beams])) & (rho <= HORIZON)
    home = (px >= -ROBOT.rear_offset) & (px <= ROBOT.front_offset) & (np.abs(py) <= ROBOT.width / 2)
    out: np.ndarray = ray | home
    return out


# -- the body along a plan --------------------------------------------------------------------
def _body_samples() -> np.ndarray:
    rear, front, half = ROBOT.rear_offset - INSET, ROBOT.front_offset - INSET, ROBOT.width / 2 - INSET
    us, vs = np.arange(-rear, front + 1e-9, 0.01), np.arange(-half, half + 1e-9, 0.01)
    grid = np.array([(u, v) for u in us for v in vs])
    edge = []
    for (a, b), (c, d) in (((-rear, -half), (front, -half)), ((front, -half), (front, half)),
                           ((front, half), (-rear, half)), ((-rear, half), (-rear, -half))):
        n = int(math.ceil(math.hypot(c - a, d - b) / 0.003))
        edge += [(a + (c - a) * i / n, b + (d - b) * i / n) for i in range(n)]
    return np.vstack((grid, np.array(edge)))


BODY = _body_samples()


def poses(step) -> list[tuple[float, float, float]]:
    s, e = step.start, step.end
    if step.task.value == "STRAIGHT":
        n = max(1, int(math.ceil(math.hypot(e.x - s.x, e.y - s.y) / 0.005)))
        return [(s.x + (e.x - s.x) * i / n, s.y + (e.y - s.y) * i / n, s.theta) for i in range(n + 1)]
    turned = math.atan2(math.sin(e.theta - s.theta), math.cos(e.theta - s.theta))
    if step.task.value == "LEFT" and turned < 0:
        turned += 2 * math.pi
    if step.task.value == "RIGHT" and turned > 0:
        turned -= 2 * math.pi
    n = max(1, int(math.ceil(abs(turned) / 0.01)))
    return [(s.x, s.y, s.theta + turned * i / n) for i in range(n + 1)]


def body_seen(step, ranges: np.ndarray, phase: float) -> bool:
    """True when every sample of the body along ``step`` lies where a ray went."""
    ps = np.array(poses(step))
    c, s = np.cos(ps[:, 2])[:, None], np.sin(ps[:, 2])[:, None]
    px = ps[:, 0:1] + BODY[:, 0] * c - BODY[:, 1] * s
    py = ps[:, 1:2] + BODY[:, 0] * s + BODY[:, 1] * c
    return bool(crossed(px.ravel(), py.ravel(), ranges, phase).all())


# -- scenes: posts behind posts ---------------------------------------------------------------
@st.composite
def post_fields(draw: st.DrawFn) -> tuple[list[tuple[str, float, float, float, float]], tuple[float, float], int, float]:
    posts: list[tuple[str, float, float, float, float]] = []

    def post(d: float, bearing: float) -> None:
        kind = draw(st.sampled_from(["square", "round"]))
        size = draw(st.floats(0.02, 0.06)) if kind == "square" else draw(st.floats(0.01, 0.03))
        posts.append((kind, d * math.cos(bearing), d * math.sin(bearing), size, draw(st.floats(0.0, math.pi / 2))))

    for _ in range(draw(st.integers(1, 4))):
        d, bearing = draw(st.floats(0.3, 0.8)), draw(st.floats(-0.6, 0.6))
        post(d, bearing)
        for _ in range(draw(st.integers(0, 3))):  # in its shadow, or nearly
            post(d + draw(st.floats(0.08, 0.5)), bearing + draw(st.floats(-0.05, 0.05)))
    goal = (draw(st.floats(0.5, 1.05)), draw(st.floats(-0.5, 0.5)))
    return posts, goal, draw(st.sampled_from([360, 500, 720])), draw(st.floats(0.0, 1.0))


def _plan(posts, goal, beams, phase):
    ranges = raycast(posts, beams, phase)
    try:
        result = Configurator().plan(returns(ranges, phase), goal)
    except PlanningError:
        assume(False)
    return result, ranges


@settings(max_examples=60)
@given(post_fields())
def test_no_plan_passes_through_space_no_ray_crossed_before_its_last_task(field) -> None:
    posts, goal, beams, phase = field
    result, ranges = _plan(posts, goal, beams, phase)
    steps = result.steps
    for i, step in enumerate(steps[:-1]):
        assert body_seen(step, ranges, phase), f"task {i} ({step.task.value}) of {len(steps)} passes through a shadow"


@settings(max_examples=60)
@given(post_fields())
def test_a_plan_that_claims_the_goal_lies_wholly_where_rays_went(field) -> None:
    posts, goal, beams, phase = field
    result, ranges = _plan(posts, goal, beams, phase)
    assume(result.reached_goal)
    for i, step in enumerate(result.steps):
        assert body_seen(step, ranges, phase), f"claims the goal, but task {i} ({step.task.value}) passes through a shadow"


@settings(max_examples=200)
@given(post_fields(), st.floats(-0.2, 1.2), st.floats(-0.8, 0.8))
def test_known_free_space_is_never_more_than_the_rays_crossed(field, x, y) -> None:
    posts, _, beams, phase = field
    ranges = raycast(posts, beams, phase)
    free = KnownFree.from_points(returns(ranges, phase), HORIZON, robot=ROBOT)
    if free.contains(x, y):
        assert crossed(np.array([x]), np.array([y]), ranges, phase)[0]


@settings(max_examples=150)
@given(post_fields(), st.floats(0.0, 0.9), st.floats(-0.6, 0.6), st.floats(-math.pi, math.pi),
       st.floats(0.0, 0.4), st.floats(-math.pi, math.pi))
def test_a_clear_sweep_lies_where_rays_went(field, x, y, theta, distance, angle) -> None:
    # the check itself, on poses the planner might never reach: straights and turns it
    # calls clear have every body sample where a ray went
    posts, _, beams, phase = field
    ranges = raycast(posts, beams, phase)
    free = KnownFree.from_points(returns(ranges, phase), HORIZON, robot=ROBOT)
    start = Pose(x, y, theta)

    class Step:  # what body_seen reads of a plan step
        def __init__(self, kind: str, end: Pose) -> None:
            self.task = type("T", (), {"value": kind})()
            self.start, self.end = start, end

    if free.straight_clear(start, distance, ROBOT):
        end = Pose(x + distance * math.cos(theta), y + distance * math.sin(theta), theta)
        assert body_seen(Step("STRAIGHT", end), ranges, phase)
    if free.turn_clear(start, angle, ROBOT):
        assert body_seen(Step("LEFT" if angle >= 0 else "RIGHT", Pose(x, y, theta + angle)), ranges, phase)


def test_a_post_hidden_behind_a_post_is_not_driven_through() -> None:
    # the scene in small: a 4 cm post at 0.4 m hides one at 0.8 m, the goal behind both
    posts = [("square", 0.4, 0.0, 0.04, 0.0), ("square", 0.8, 0.0, 0.04, 0.0)]
    ranges = raycast(posts, 720, 0.5)
    assert np.isfinite(ranges).sum() > 0 and not (np.abs(returns(ranges, 0.5)[:, 0] - 0.78) < 0.01).any()  # unseen
    result = Configurator().plan(returns(ranges, 0.5), (1.0, 0.0))
    for step in result.steps[:-1]:
        assert body_seen(step, ranges, 0.5)
    assert not result.reached_goal  # the goal stands in the shadow: a frontier end, never a claim
    assert result.stop_reason == "frontier"


def test_in_the_open_the_goal_is_still_reached() -> None:
    # the rule takes nothing from space the rays crossed: no posts, or posts off to the side
    for posts in ([], [("round", 0.5, 0.5, 0.02, 0.0), ("square", 0.6, -0.45, 0.04, 0.3)]):
        ranges = raycast(posts, 720, 0.0)
        result = Configurator().plan(returns(ranges, 0.0), (1.0, 0.0))
        assert result.reached_goal and result.collision_free
