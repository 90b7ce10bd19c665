"""The recording of a ``roles-formation`` run, read back and measured.

From the bag:

- ``/roles/assignment``: the negotiation rounds (who plays which role, goals, excluded robots);
- ``/roles/channel``: every process role published (the engine's initial ones, version 0, and
  the players' re-optimised ones), i.e. the *commanded* trajectories; ``arrived`` flags;
- ``/ground_truth/bodies``: the robots' true positions (the *tracked* trajectories of the plots
  and every distance measure: the camera tracker's estimates are not recorded, the truth is
  what a collision is about);
- ``/<robot>/cmd_vel``: the controller's commands.

Results (:func:`formation_results`): ``completed`` (the last round assigned roles and every
robot of it reported ``arrived``), ``min_distance`` (least ground-truth distance between two
robot centres over the whole recording) with its pair and ``sum_of_radii``, ``min_clearance``
(least distance minus the pair's sum of radii), ``robot_collisions`` (onsets of a pair closer
than its sum of radii), the robot-obstacle clearance of every robot against the map's boxes
(:func:`.path_measures.obstacle_clearances`: ``obstacle_clearance`` per robot,
``min_obstacle_clearance``, ``obstacle_contacts``), ``collisions`` = robot collisions + obstacle
contacts, and per robot of the last round its role, goal, ``arrival_time`` (s from the
round's role start to the player's ``arrived`` message), ``final_error`` (ground-truth distance
to the goal at the end) and the tracking error (ground truth vs the commanded role at the same
time).

:func:`formation_outcome` is the report's line for such a bag (registered with scripts/report through
the ament index resource ``collab_report_plots``): formed or not, how many robots arrived, when.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from collab_tools.core.bag_analysis import BagSummary, read_messages
from collab_tools.core.run_outcome import Outcome, register_outcome

from ..core.trajectory import interpolate
from .path_measures import ObstacleBox, obstacle_clearances, separation_measures

ASSIGNMENT = '/roles/assignment'
CHANNEL = '/roles/channel'
GROUND_TRUTH = '/ground_truth/bodies'


def _stamp(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


# ------------------------------------------------------------------------------- bag reading
@dataclass(frozen=True)
class AssignmentRecord:
    stamp: float
    round: int
    status: str
    message: str
    goals: dict[str, tuple[float, float]]      # robot -> goal
    role_ids: dict[str, str]
    excluded: list[str]
    start_time: float | None                    # the round's roles' start time (s, sim clock)
    session: int = 0                            # the engine's session (a restarted engine counts rounds anew)


@dataclass(frozen=True)
class RoleRecord:
    stamp: float
    round: int
    version: int
    start_time: float
    total_time: float
    trajectory: np.ndarray
    arrived: bool
    session: int = 0

    def position(self, t: float) -> np.ndarray:
        return interpolate(self.trajectory, self.total_time, [t - self.start_time])[0][0]


@dataclass
class FormationLog:
    """What one recorded run holds, per robot."""

    assignments: list[AssignmentRecord] = field(default_factory=list)
    roles: dict[str, list[RoleRecord]] = field(default_factory=dict)
    truth_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    truth: dict[str, np.ndarray] = field(default_factory=dict)          # (K, 2) per robot
    commands: dict[str, np.ndarray] = field(default_factory=dict)       # (M, 3): t, linear, angular


def _role_record(msg) -> RoleRecord:
    states = np.column_stack([msg.x, msg.y, msg.vx, msg.vy]).astype(float)
    if len(states) < 2 or not (msg.dt > 0):
        raise ValueError(f'process role of {msg.robot!r} (round {msg.round}, version {msg.version}): needs >= 2 '
                         f'states and dt > 0 (got {len(states)}, {msg.dt})')
    return RoleRecord(_stamp(msg.header), int(msg.round), int(msg.version), float(msg.start_time),
                      float(msg.dt) * (len(states) - 1), states, bool(msg.arrived), int(getattr(msg, 'session', 0)))


def final_assignment(assignments: list[AssignmentRecord]) -> AssignmentRecord | None:
    """The run's last round: the highest round of the last engine session recorded (bag order), so a
    restarted engine's rounds 1, 2, ... are not hidden behind the first engine's higher ones."""
    if not assignments:
        return None
    session = assignments[-1].session
    return max((a for a in assignments if a.session == session), key=lambda a: a.round)


def _of_round(roles: list[RoleRecord], final: AssignmentRecord) -> list[RoleRecord]:
    return [r for r in roles if r.round == final.round and r.session == final.session]


def read_formation_bag(bag: Path, robots: list[str]) -> FormationLog:
    """The run's assignments, roles, ground truth and commands of ``robots`` (bag time order)."""
    command_topics = {f'/{robot}/cmd_vel': robot for robot in robots}
    log = FormationLog(roles={r: [] for r in robots})
    truth_times, truth = [], {r: [] for r in robots}
    commands = {r: [] for r in robots}
    for topic, log_ns, msg in read_messages(bag, [ASSIGNMENT, CHANNEL, GROUND_TRUTH, *command_topics]):
        if topic == ASSIGNMENT:
            starts = {r.start_time for r in msg.initial_roles}
            log.assignments.append(AssignmentRecord(
                _stamp(msg.header), int(msg.round), msg.status, msg.message,
                {r: (float(x), float(y)) for r, x, y in zip(msg.robots, msg.goal_x, msg.goal_y)},
                dict(zip(msg.robots, msg.role_ids)), list(msg.excluded_robots),
                min(starts) if starts else None, int(getattr(msg, 'session', 0))))
        elif topic == CHANNEL:
            if msg.robot in log.roles:
                log.roles[msg.robot].append(_role_record(msg))
        elif topic == GROUND_TRUTH:
            seen = {b.name: b.pose.position for b in msg.bodies}
            if all(r in seen for r in robots):
                truth_times.append(_stamp(msg.header))
                for r in robots:
                    truth[r].append([seen[r].x, seen[r].y])
        else:
            commands[command_topics[topic]].append([log_ns * 1e-9, msg.linear.x, msg.angular.z])
    order = np.argsort(truth_times, kind='stable')
    log.truth_times = np.asarray(truth_times, dtype=float)[order]
    log.truth = {r: np.asarray(p, dtype=float).reshape(-1, 2)[order] for r, p in truth.items()}
    log.commands = {r: np.asarray(c, dtype=float).reshape(-1, 3) for r, c in commands.items()}
    return log


def commanded_positions(roles: list[RoleRecord], times: np.ndarray, round_: int | None = None) -> np.ndarray:
    """(K, 2) position of the role in force at each time (the latest one stamped <= t; NaN before any)."""
    chosen = sorted((r for r in roles if round_ is None or r.round == round_), key=lambda r: r.stamp)
    out = np.full((len(times), 2), np.nan)
    stamps = np.array([r.stamp for r in chosen])
    for k, t in enumerate(times):
        index = int(np.searchsorted(stamps, t, side='right')) - 1
        if index >= 0:
            out[k] = chosen[index].position(t)
    return out


# ----------------------------------------------------------------------------------- results
def formation_results(log: FormationLog, radii: dict[str, float], arrival_tolerance: float,
                      obstacles: list[ObstacleBox] | None = None) -> dict:
    """results.json of a run from its bag (module docstring); ``obstacles``: the static boxes of the
    simulated world (walls included) the clearance is measured against. Never raises on an unfinished run."""
    robots = sorted(radii)
    if len(log.truth_times) == 0:
        raise ValueError(f'the bag has no {GROUND_TRUTH} message with every robot ({", ".join(robots)})')
    separation = separation_measures(log.truth, radii, log.truth_times)
    separation['robot_collisions'] = separation['collisions']
    clearance = obstacle_clearances(log.truth, radii, list(obstacles or []), log.truth_times)
    separation.update(clearance, collisions=separation['robot_collisions'] + clearance['obstacle_contacts'])
    final = final_assignment(log.assignments)
    results = {'rounds': [{'round': a.round, 'session': a.session, 'status': a.status, 'message': a.message,
                           'robots': sorted(a.goals), 'excluded': a.excluded} for a in log.assignments],
               **separation, 'recorded_s': float(log.truth_times[-1] - log.truth_times[0]), 'robots': {}}
    assigned = final is not None and final.status == 'assigned'
    completed = assigned
    for robot in (sorted(final.goals) if assigned else []):
        roles = _of_round(log.roles.get(robot, []), final)
        arrived = next((r for r in sorted(roles, key=lambda r: r.stamp) if r.arrived), None)
        goal = np.asarray(final.goals[robot])
        final_error = float(np.hypot(*(log.truth[robot][-1] - goal)))
        in_round = log.truth_times >= (final.start_time if final.start_time is not None else final.stamp)
        commanded = commanded_positions(roles, log.truth_times[in_round])
        valid = ~np.isnan(commanded[:, 0])
        error = np.hypot(*(commanded[valid] - log.truth[robot][in_round][valid]).T)
        results['robots'][robot] = {
            'role_id': final.role_ids[robot], 'goal': goal.tolist(), 'radius': radii[robot],
            'arrived': arrived is not None,
            'arrival_time': None if arrived is None or final.start_time is None
            else arrived.stamp - final.start_time,
            'final_error': final_error, 'within_tolerance': final_error <= arrival_tolerance,
            'tracking_error_rms': float(np.sqrt(np.mean(error**2))) if len(error) else None,
            'tracking_error_max': float(error.max()) if len(error) else None,
            'process_roles_published': len(roles),
            'min_obstacle_clearance': clearance['obstacle_clearance'][robot]['min_clearance'],
            'obstacle_contacts': clearance['obstacle_clearance'][robot]['contacts']}
        completed = completed and arrived is not None
    results.update({'completed': bool(completed), 'final_round': final.round if final else None,
                    'final_status': final.status if final else 'no assignment', 'arrival_tolerance': arrival_tolerance})
    return results


# ----------------------------------------------------------------------------------- outcome
ASSIGNMENT_TYPE = 'role_interfaces/msg/RoleAssignment'


def formation_outcome(bag: Path, summary: BagSummary | None = None) -> Outcome | None:
    """formed (the last round assigned roles and every robot of it arrived) or not, with the arrivals,
    the time to form (last arrival after the round's roles started) and the largest final distance to
    a goal (ground truth); None for a bag without assignments."""
    robots = sorted({r for _, _, msg in read_messages(bag, [ASSIGNMENT]) for r in msg.robots})
    log = read_formation_bag(bag, robots)
    if not log.assignments:
        return None
    final = final_assignment(log.assignments)
    rounds = len({(a.session, a.round) for a in log.assignments})
    if final.status != 'assigned':
        return Outcome('roles', 'not formed', f'round {final.round} {final.status}: {final.message}'[:300],
                       passed=False, figures={'rounds': rounds, 'final_status': final.status},
                       checks={'formed': False})
    arrivals = {}
    for robot in final.goals:
        arrived = sorted((r.stamp for r in _of_round(log.roles.get(robot, []), final) if r.arrived))
        if arrived:
            arrivals[robot] = arrived[0]
    errors = {robot: float(np.hypot(*(log.truth[robot][-1] - np.asarray(goal))))
              for robot, goal in final.goals.items() if len(log.truth.get(robot, ()))}
    formed = len(arrivals) == len(final.goals)
    start = final.start_time if final.start_time is not None else final.stamp
    time_to_form = max(arrivals.values()) - start if formed and arrivals else None
    text = (f'{len(arrivals)}/{len(final.goals)} robots arrived at their roles in round {final.round}'
            + (f' after {time_to_form:.1f} s' if time_to_form is not None else '')
            + (f'; largest final distance to a goal {max(errors.values()):.2f} m' if errors else ''))
    return Outcome('roles', 'formed' if formed else 'not formed', text, passed=formed,
                   figures={'rounds': rounds, 'arrived': sorted(arrivals), 'time_to_form_s': time_to_form,
                            'final_error_m': errors},
                   checks={'formed': formed})


register_outcome('roles_formation', {ASSIGNMENT_TYPE}, formation_outcome)
