"""Yielding in narrow passages: who gives way, where it waits, and when it goes on (Sec. V-A-4).

In a passage narrower than two robots side by side no sideways detour resolves a head-on
conflict; the paper's role players "update process roles close to the place where the
conflict is happening", so one robot lets the other pass. This module gives the pieces the
role-playing update (:mod:`.role_playing`) needs for that, all from what a robot has on the
shared channel (its own and the others' process roles) and its map -- no central arbiter.

**Who yields** (:func:`right_of_way`). Two roles conflict when their centres come closer
than ``r_i + r_j + clearance`` at the same time. At the first such instant the midpoint of
the two positions is the *meeting point*. The *conflict area* is the narrow region around
it: the 8-connected component, containing the meeting point, of the free cells whose
workspace clearance (the map's SDF, the same for every robot type) is below
``r_i + r_j + clearance / 2`` -- on the centre line of a passage narrower than
``2 (r_i + r_j) + clearance`` two robots cannot pass side by side. In the open (the meeting
point is not in such a region) the conflict area is the disc of radius
``r_i + r_j + clearance`` around the meeting point. Each robot's *entry time* is the first
instant from ``now`` at which its role is inside the conflict area (``now`` if it already
is). The robot that enters first keeps its role (first come, first served at the
bottleneck); on equal entry times the robot whose name sorts first keeps it. Both robots
compute the rule on the same pair of roles in the same (name-sorted) order, so from one
snapshot of the channel they reach opposite answers: exactly one of them yields.

**Where it waits** (:func:`waiting_plans`). Waiting spots are visitable cells whose
configuration-space clearance is at least ``spot_clearance`` (the GP's safety distance, so
the obstacle hinge is inactive there) and which every role the robot yields to keeps at
least ``r_i + r_j + clearance`` away over its whole remaining time (it must be able to pass
and reach its goal). Spots are ranked by the detour ``d(position, spot) + d(spot, goal)``
(shortest 8-connected paths on the visitable cells, reduced by line of sight), then by
clearance, so the robot waits close to its way -- holding position when that already
qualifies, backing off along its path or into the wider free space next to it otherwise.

**When it goes on.** The waiting plan drives to the spot at ``speed``, holds there, and
then follows the shortest path from the spot to its goal at ``speed``. The release time is
the earliest one (on a grid of ``release_step`` seconds) at which the whole timed plan
keeps ``r_i + r_j + clearance`` from every other role at every common instant; spots whose
approach already conflicts, or that are never released, are skipped. The plan's duration
follows from the path lengths and the speed, so the role's total time grows as needed
instead of asking for more than the speed limit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from .astar import polyline_length, reduce_by_line_of_sight
from .conflict import SharedRole
from .environment import EIGHT_CONNECTED, RobotEnvironment

#: Instants per second at which roles are compared (entry times, spot and release checks).
CHECK_RATE = 10.0
#: 8-neighbour offsets (dy, dx) of the grid graph.
_NEIGHBOURS = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dy, dx) != (0, 0)]


@dataclass(frozen=True)
class PairConflict:
    """Two roles in conflict: the meeting point and when each enters the conflict area."""

    first_time: float                 # first instant closer than r_i + r_j + clearance [s]
    meeting_point: tuple[float, float]
    narrow: bool                      # the meeting point lies in a passage too narrow to pass in
    entry_times: dict[str, float]     # robot name -> first instant inside the conflict area [s]
    keeps_role: str                   # the robot with the right of way


def _check_times(now: float, *roles: SharedRole) -> np.ndarray:
    end = max(role.start_time + role.total_time for role in roles)
    count = max(2, int(math.ceil(max(end - now, 0.0) * CHECK_RATE)) + 1)
    return now + np.linspace(0.0, max(end - now, 1.0 / CHECK_RATE), count)


def pair_conflict(first: SharedRole, second: SharedRole, robot_env: RobotEnvironment, now: float,
                  clearance: float) -> PairConflict | None:
    """The conflict of two roles from ``now`` on and who keeps its role (module docstring); None if none.

    Symmetric in its arguments: the roles are compared in name order.
    """
    a, b = sorted((first, second), key=lambda role: role.name)
    times = _check_times(now, a, b)
    positions_a, positions_b = a.positions(times), b.positions(times)
    separation = a.radius + b.radius + clearance
    close = np.flatnonzero(np.hypot(*(positions_a - positions_b).T) < separation)
    if close.size == 0:
        return None
    k = int(close[0])
    meeting = 0.5 * (positions_a[k] + positions_b[k])
    inside, narrow = _conflict_area(robot_env, meeting, a.radius + b.radius + 0.5 * clearance, separation)
    entry = {}
    for role, positions in ((a, positions_a), (b, positions_b)):
        hits = np.flatnonzero(inside(positions))
        entry[role.name] = float(times[hits[0]]) if hits.size else math.inf
    keeps = min((a.name, b.name), key=lambda name: (entry[name], name))
    return PairConflict(float(times[k]), (float(meeting[0]), float(meeting[1])), narrow, entry, keeps)


def right_of_way(own: SharedRole, other: SharedRole, robot_env: RobotEnvironment, now: float,
                 clearance: float) -> bool | None:
    """Whether ``own`` keeps its role against ``other`` (True) or yields (False); None without conflict."""
    conflict = pair_conflict(own, other, robot_env, now, clearance)
    return None if conflict is None else conflict.keeps_role == own.name


def _conflict_area(robot_env: RobotEnvironment, meeting: np.ndarray, narrow_below: float, separation: float):
    """(points (n, 2) -> inside (n,) bool, narrow): the narrow component around ``meeting`` or a disc."""
    workspace = robot_env.environment.sdf
    frame = robot_env.frame
    narrow = (workspace.data > 0.0) & (workspace.data < narrow_below)
    cell = frame.world_to_cell(np.asarray(meeting, dtype=float)[None, :])[0]
    if frame.contains_cells(cell[None, :])[0] and narrow[cell[0], cell[1]]:
        labels, _ = ndimage.label(narrow, structure=EIGHT_CONNECTED)
        region = labels == labels[cell[0], cell[1]]

        def inside(points: np.ndarray) -> np.ndarray:
            cells = frame.world_to_cell(np.asarray(points, dtype=float))
            result = frame.contains_cells(cells)
            result[result] = region[cells[result, 0], cells[result, 1]]
            return result
        return inside, True
    return (lambda points: np.hypot(*(np.asarray(points) - meeting).T) < separation), False


# ------------------------------------------------------------------------------ waiting plans
@dataclass
class WaitingPlan:
    """A timed piecewise-linear initialisation: drive to ``spot``, hold until ``release``, go to the goal."""

    label: str
    spot: tuple[float, float]
    arrive: float                     # absolute time at the spot [s]
    release: float                    # absolute time it leaves the spot [s]
    finish: float                     # absolute time it reaches the goal [s]
    knot_times: np.ndarray            # (K,) absolute, non-decreasing
    knot_points: np.ndarray           # (K, 2)

    def positions(self, times) -> np.ndarray:
        times = np.asarray(times, dtype=float)
        return np.stack([np.interp(times, self.knot_times, self.knot_points[:, axis]) for axis in (0, 1)], axis=1)

    def states(self, support_times: np.ndarray, start: np.ndarray) -> np.ndarray:
        """(N+1, 4) states at ``support_times``: positions of the plan, velocities by central differences;
        the first state is ``start`` (tracked position, current velocity), the last one at rest."""
        positions = self.positions(support_times)
        velocities = np.gradient(positions, support_times, axis=0)
        states = np.hstack([positions, velocities])
        states[0] = start
        states[-1, 2:] = 0.0
        return states


def _timed(points: np.ndarray, speed: float, t0: float) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(points, dtype=float)
    keep = np.concatenate([[True], np.hypot(*np.diff(points, axis=0).T) > 1e-9])
    points = points[keep]
    lengths = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    return t0 + lengths / speed, points


class _GridGraph:
    """Shortest 8-connected paths on a robot type's visitable cells (lengths in m)."""

    def __init__(self, robot_env: RobotEnvironment):
        self.env = robot_env
        self.free = np.asarray(robot_env.visitable)
        ny, nx = self.free.shape
        index = np.arange(ny * nx).reshape(ny, nx)
        rows, cols, weights = [], [], []
        step = robot_env.frame.resolution
        for dy, dx in _NEIGHBOURS:
            ys = slice(max(-dy, 0), ny - max(dy, 0))
            xs = slice(max(-dx, 0), nx - max(dx, 0))
            target_ys = slice(max(dy, 0), ny - max(-dy, 0))
            target_xs = slice(max(dx, 0), nx - max(-dx, 0))
            both = self.free[ys, xs] & self.free[target_ys, target_xs]
            rows.append(index[ys, xs][both])
            cols.append(index[target_ys, target_xs][both])
            weights.append(np.full(int(both.sum()), step * math.hypot(dy, dx)))
        size = ny * nx
        self.graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                                shape=(size, size)).tocsr()
        self.shape = (ny, nx)

    def nearest_free_cell(self, point) -> tuple[int, int] | None:
        frame = self.env.frame
        cell = frame.world_to_cell(np.asarray(point, dtype=float)[None, :])[0]
        if frame.contains_cells(cell[None, :])[0] and self.free[cell[0], cell[1]]:
            return int(cell[0]), int(cell[1])
        free_cells = np.argwhere(self.free)
        if free_cells.size == 0:
            return None
        centres = frame.cell_to_world(free_cells)
        best = free_cells[int(np.argmin(np.hypot(*(centres - np.asarray(point, dtype=float)).T)))]
        return int(best[0]), int(best[1])

    def tree(self, cell: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Distances (ny, nx) [m] from ``cell`` and the predecessor of every node."""
        source = cell[0] * self.shape[1] + cell[1]
        distances, predecessors = dijkstra(self.graph, directed=False, indices=source, return_predecessors=True)
        return distances.reshape(self.shape), predecessors

    def path(self, predecessors: np.ndarray, cell: tuple[int, int]) -> np.ndarray:
        """World points from ``cell`` back along ``predecessors`` to the tree's root, line-of-sight reduced."""
        node = cell[0] * self.shape[1] + cell[1]
        chain = [node]
        while predecessors[chain[-1]] >= 0:
            chain.append(int(predecessors[chain[-1]]))
        cells = np.column_stack(np.unravel_index(np.array(chain), self.shape))
        kept = reduce_by_line_of_sight(cells, self.free)
        return self.env.frame.cell_to_world(cells[kept])


def _min_gap(plan_positions: np.ndarray, times: np.ndarray, own_radius: float,
             others: list[SharedRole]) -> float:
    gaps = [np.min(np.hypot(*(other.positions(times) - plan_positions).T)) - own_radius - other.radius
            for other in others]
    return float(min(gaps, default=math.inf))


def waiting_plans(robot_env: RobotEnvironment, own_radius: float, position, goal, now: float,
                  yield_to: list[SharedRole], others: list[SharedRole], *, clearance: float, speed: float,
                  spot_clearance: float, release_step: float = 0.25, max_plans: int = 2,
                  max_spots: int = 12) -> list[WaitingPlan]:
    """Up to ``max_plans`` waiting plans that let every role in ``yield_to`` pass first (module docstring).

    ``others`` are all other robots' roles (the timed plan must keep clear of them all). The
    first ``max_spots`` spots in the detour order, each at least ``2 r_i + clearance`` from
    the spots before it (so they differ), are timed; the plans that reach the goal first are
    returned, earliest first. Empty when no spot qualifies.
    """
    position = np.asarray(position, dtype=float)
    goal = np.asarray(goal, dtype=float)
    graph = _GridGraph(robot_env)
    start_cell, goal_cell = graph.nearest_free_cell(position), graph.nearest_free_cell(goal)
    if start_cell is None or goal_cell is None:
        return []
    from_start, start_tree = graph.tree(start_cell)
    to_goal, goal_tree = graph.tree(goal_cell)
    frame = robot_env.frame
    clearance_map = robot_env.sdf.data
    candidates = graph.free & np.isfinite(from_start) & np.isfinite(to_goal) & (clearance_map >= spot_clearance)
    cells = np.argwhere(candidates)
    if cells.size == 0:
        return []
    centres = frame.cell_to_world(cells)
    keep = np.ones(len(cells), dtype=bool)
    for role in yield_to:
        times = _check_times(now, role)
        distance, _ = cKDTree(role.positions(times)).query(centres)
        keep &= distance >= own_radius + role.radius + clearance
    cells, centres = cells[keep], centres[keep]
    detour = from_start[cells[:, 0], cells[:, 1]] + to_goal[cells[:, 0], cells[:, 1]]
    order = np.lexsort((-clearance_map[cells[:, 0], cells[:, 1]], np.round(detour / frame.resolution)))
    plans: list[tuple[float, int, WaitingPlan]] = []
    tried: list[np.ndarray] = []
    for rank, index in enumerate(order):
        if len(tried) >= max_spots:
            break
        spot = centres[index]
        if any(math.dist(spot, earlier) < 2.0 * own_radius + clearance for earlier in tried):
            continue
        tried.append(spot)
        cell = (int(cells[index, 0]), int(cells[index, 1]))
        approach = np.vstack([position, graph.path(start_tree, cell)[::-1][1:-1], spot])
        resume = np.vstack([spot, graph.path(goal_tree, cell)[1:-1], goal])
        plan = _released(approach, resume, spot, now, own_radius, others, clearance, speed, release_step)
        if plan is not None:
            plans.append((plan.finish, rank, plan))
    return [plan for _, _, plan in sorted(plans, key=lambda entry: entry[:2])[:max_plans]]


def _released(approach: np.ndarray, resume: np.ndarray, spot: np.ndarray, now: float, own_radius: float,
              others: list[SharedRole], clearance: float, speed: float, step: float) -> WaitingPlan | None:
    """The plan with the earliest release time that keeps clear of every other role, or None."""
    approach_times, approach_points = _timed(approach, speed, now)
    arrive = float(approach_times[-1])
    resume_duration = polyline_length(resume) / speed
    latest = max([arrive] + [o.start_time + o.total_time for o in others]) + resume_duration + step
    kind = 'hold at' if polyline_length(approach) < 0.1 else 'back off to'
    label_spot = f'({spot[0]:.2f}, {spot[1]:.2f})'
    # The approach alone (and holding at the spot up to the arrival) must already be clear.
    times = now + np.arange(0.0, arrive - now + 1e-9, 1.0 / CHECK_RATE)
    if times.size and _min_gap(np.stack([np.interp(times, approach_times, approach_points[:, a])
                                         for a in (0, 1)], axis=1), times, own_radius, others) < clearance:
        return None
    def plan_released_at(release: float) -> WaitingPlan | None:
        resume_times, resume_points = _timed(resume, speed, release)
        finish = float(resume_times[-1])
        plan = WaitingPlan(f'{kind} {label_spot} until {release:.1f} s', (float(spot[0]), float(spot[1])),
                           arrive, release, finish, np.concatenate([approach_times, resume_times]),
                           np.vstack([approach_points, resume_points]))
        end = max([finish] + [o.start_time + o.total_time for o in others])
        check = now + np.arange(0.0, end - now + 1.0 / CHECK_RATE, 1.0 / CHECK_RATE)
        return plan if _min_gap(plan.positions(check), check, own_radius, others) >= clearance else None

    # Coarse scan in steps of 4 ``step``, then the earliest release on the fine grid just before it.
    coarse = arrive
    while coarse <= latest:
        plan = plan_released_at(coarse)
        if plan is not None:
            for fine in np.arange(max(arrive, coarse - 3.0 * step), coarse - 0.5 * step, step):
                earlier = plan_released_at(float(fine))
                if earlier is not None:
                    return earlier
            return plan
        coarse += 4.0 * step
    return None
