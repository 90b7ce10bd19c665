"""The formation task of the role nodes: its settings, the team, the roles and the re-planning step.

Settings file (YAML, e.g. config/roles/formation_demo.yaml; unknown keys are errors)::

    scenario: ../scenarios/roles_formation.yaml  # the bridge scenario (robots, types, colours), relative;
                                   # read by the role engine only (players get the team over ROS)
    formation: {type: diamond, center: [0, 0], size: 2.0, rotation: 0.0}
                                   # circle | square | diamond | line (core/formations.py); the number of
                                   # points is the number of robots taking part in the negotiation round
    trajectory: {total_time: 20.0, states: 41}   # s > 0; support states N+1 >= 2
    grid_resolution: 0.05          # m per cell of the environment built from the camera image, > 0
    inflation_margin: 0.03         # m added to every robot's radius for the planners' views, >= 0
    speed_fraction: 0.8            # GP speed limit (Eq. 22) as a share of the type's max speed, (0, 1]
    gp: {sigma_obs: 0.1, ...}      # GPPlannerConfig fields (core/gp_planner.py) except robot_radius, max_speed
    qualification_lambda: 1.0      # lambda of Q = lambda F_gp + F_conf (Eq. 13), >= 0
    start_delay: 2.0               # s between publishing an assignment and the roles' start time, >= 0
    silence_timeout: 4.0           # s without a process role from a robot before it counts as silent, > 0
    replan_period: 1.0             # s between re-optimisations of a role player, > 0
    conflict_horizon: 4.0          # s of the others' roles checked for conflicts (Algorithm 4 line 3), >= 0
    arrival_tolerance: 0.08        # m from the destination at which a robot has arrived, > 0
    robot_avoidance: {clearance: 0.1, sigma: 0.02, interpolation: 3, detour_scales: [1.0, 2.0]}
                                   # the others as moving obstacles (core/role_playing.py), optional
    controller: {k_x: 1.5, k_y: 20.0, k_theta: 5.0, k_approach: 1.0, k_turn: 2.0}
                                   # the role players' tracking gains (core/controller.py), optional
    problem_detection: {stuck_distance: 0.05, stuck_time: 8.0, off_role_distance: 0.6, off_role_grace: 4.0}
                                   # Algorithm 1's "detect a problem" (core/problems.py), optional
    min_robots: 2                  # fewer usable robots than this: the engine aborts, >= 1

Where the paper is silent: when a robot drops out, the remaining robots renegotiate the
same formation (type, centre, size) with one point per remaining robot, and the silent
robot, which stops once its commands stop, is a static obstacle for them. The formation
needs ``min_robots`` robots; with fewer usable ones the task is not negotiable (aborted).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from collab_tools.core.fields import Fields, fail, join_path, read_yaml_file

from .controller import TrackingGains
from .environment import MAX_GRID_CELLS, RobotEnvironment, RobotType
from .errors import RoleEngineError
from .formations import parse_formation
from .gp_planner import GPPlanner, GPPlannerConfig
from .negotiation import Role
from .problems import ProblemSettings
from .qualification import ProcessRoleEvaluation
from .role_playing import AvoidanceSettings, Replan, replan_process_role  # noqa: F401 (re-exported)

TOP_LEVEL_KEYS = ('scenario', 'formation', 'trajectory', 'grid_resolution', 'inflation_margin', 'speed_fraction',
                  'gp', 'qualification_lambda', 'start_delay', 'silence_timeout', 'replan_period',
                  'conflict_horizon', 'arrival_tolerance', 'robot_avoidance', 'problem_detection', 'min_robots',
                  'controller')
#: GP fields the task sets itself, per robot type.
GP_FIELDS_SET_HERE = ('robot_radius', 'max_speed')
#: Most support states of a trajectory: what a role player accepts in a process role
#: (role_messages.MAX_ROLE_STATES); 41 in the paper. A 100,001-state plan took 4.9 s, 1e9 states
#: would need 32 GB for the states alone.
MAX_TRAJECTORY_STATES = 10_000
#: Most GP-interpolated instants per interval (obstacle, collision-check and robot-avoidance
#: factors are states x (1 + this)): 100 keeps a plan of MAX_TRAJECTORY_STATES within ~1 M factors.
MAX_INTERPOLATION = 100


@dataclass(frozen=True)
class FormationTask:
    """The validated settings file (see the module docstring)."""

    source: Path
    scenario: Path
    formation: dict
    total_time: float
    states: int
    grid_resolution: float
    inflation_margin: float
    speed_fraction: float
    gp: dict
    qualification_lambda: float
    start_delay: float
    silence_timeout: float
    replan_period: float
    conflict_horizon: float
    arrival_tolerance: float
    robot_avoidance: AvoidanceSettings = AvoidanceSettings()
    problem_detection: ProblemSettings | None = None
    min_robots: int = 2
    controller: TrackingGains = TrackingGains()

    def roles(self, count: int) -> list[Role]:
        """The formation's ``count`` destinations as roles ``<type>_<k>``."""
        spec = dict(self.formation, count=int(count))
        points = parse_formation(spec, join_path(str(self.source), 'formation'))
        return [Role(f"{spec['type']}_{k}", (float(x), float(y))) for k, (x, y) in enumerate(points)]

    def gp_config(self, robot_type: RobotType) -> GPPlannerConfig:
        """GP settings of one robot type: its plans run on its own SDF, so no radius is subtracted."""
        speed = None if robot_type.max_linear_velocity is None \
            else self.speed_fraction * robot_type.max_linear_velocity
        return GPPlannerConfig.from_mapping(dict(self.gp, max_speed=speed),
                                            join_path(str(self.source), 'gp'))


def load_formation_task(path: str | Path, *, check_scenario: bool = True) -> FormationTask:
    """The settings file; ``check_scenario`` False: the scenario file need not exist (a role player
    takes the team and the map from the role engine's topics, on a machine without the scenario)."""
    path = Path(path)
    where = str(path)
    data = read_yaml_file(path, 'settings file', RoleEngineError)
    fields = Fields(data, where, allowed=TOP_LEVEL_KEYS, error=RoleEngineError)
    scenario = (path.parent / fields.string('scenario')).resolve()
    if check_scenario and not scenario.is_file():
        raise fail(fields.path_of('scenario'), f"scenario file '{scenario}' does not exist",
                   RoleEngineError)
    formation = dict(Fields(fields.raw('formation'), fields.path_of('formation'),
                            allowed=('type', 'center', 'size', 'diameter', 'side', 'width', 'length',
                                     'rotation'), error=RoleEngineError).data)
    if 'count' in formation or formation.get('type') == 'points':
        raise fail(fields.path_of('formation'), 'the count follows from the robots; give type, center, size',
                   RoleEngineError)
    trajectory = Fields(fields.raw('trajectory'), fields.path_of('trajectory'), allowed=('total_time', 'states'),
                        error=RoleEngineError)
    gp = dict(Fields(fields.raw('gp', {}), fields.path_of('gp'),
                     allowed=[name for name in GPPlannerConfig.__dataclass_fields__
                              if name not in GP_FIELDS_SET_HERE], error=RoleEngineError).data)
    task = FormationTask(
        source=path, scenario=scenario, formation=formation,
        total_time=trajectory.number('total_time', gt=0.0),
        states=trajectory.integer('states', ge=2, le=MAX_TRAJECTORY_STATES),
        grid_resolution=fields.number('grid_resolution', 0.05, gt=0.0),
        inflation_margin=fields.number('inflation_margin', 0.03, ge=0.0),
        speed_fraction=fields.number('speed_fraction', 0.8, gt=0.0, le=1.0), gp=gp,
        qualification_lambda=fields.number('qualification_lambda', 1.0, ge=0.0),
        start_delay=fields.number('start_delay', 2.0, ge=0.0),
        silence_timeout=fields.number('silence_timeout', 4.0, gt=0.0),
        replan_period=fields.number('replan_period', 1.0, gt=0.0),
        conflict_horizon=fields.number('conflict_horizon', 4.0, ge=0.0),
        arrival_tolerance=fields.number('arrival_tolerance', 0.08, gt=0.0),
        robot_avoidance=AvoidanceSettings.from_mapping(fields.raw('robot_avoidance', {}),
                                                       fields.path_of('robot_avoidance')),
        min_robots=fields.integer('min_robots', 2, ge=1),
        controller=_tracking_gains(fields.raw('controller', {}), fields.path_of('controller')))
    task = replace(task, problem_detection=ProblemSettings.from_mapping(
        fields.raw('problem_detection', {}), fields.path_of('problem_detection'),
        silence_timeout=task.silence_timeout))
    task.roles(1)                                      # validates the formation fields once
    gp_config = task.gp_config(RobotType('check', 0.1))  # and the GP fields
    for name, value in (('gp.obstacle_interpolation', gp_config.obstacle_interpolation),
                        ('gp.collision_check_interpolation', gp_config.collision_check_interpolation),
                        ('robot_avoidance.interpolation', task.robot_avoidance.interpolation)):
        if value > MAX_INTERPOLATION:
            raise fail(join_path(where, name), f'must be <= {MAX_INTERPOLATION} (got {value}; instants per '
                       'interval, each a factor of every plan)', RoleEngineError)
    return task


def check_grid_size(task: FormationTask, bounds) -> None:
    """Refuse a grid_resolution that makes the grid over ``bounds`` (xmin, ymin, xmax, ymax) too big."""
    xmin, ymin, xmax, ymax = bounds
    cells = ((xmax - xmin) / task.grid_resolution) * ((ymax - ymin) / task.grid_resolution)
    if cells > MAX_GRID_CELLS:
        raise fail(join_path(str(task.source), 'grid_resolution'),
                   f'{task.grid_resolution:g} m gives {cells:.3g} cells over the world bounds {tuple(bounds)} '
                   f'(at most {MAX_GRID_CELLS}, what the engine builds in about a second)', RoleEngineError)


def _tracking_gains(data, path: str) -> TrackingGains:
    fields = Fields(data if data is not None else {}, path, allowed=tuple(TrackingGains.__dataclass_fields__),
                    error=RoleEngineError)
    defaults = TrackingGains()
    return TrackingGains(**{name: fields.number(name, getattr(defaults, name), gt=0.0)
                            for name in TrackingGains.__dataclass_fields__})


@dataclass(frozen=True)
class TeamMember:
    """A robot of the scenario as the role nodes see it."""

    name: str
    robot_type: RobotType
    color: tuple[float, float, float]
    height: float


def team_from_scenario(scenario, inflation_margin: float) -> list[TeamMember]:
    """The scenario's mobile robots (pybullet_bridge Scenario), with the planners' inflation margin."""
    robots = scenario.sections.get('mobile_robots', [])
    if not robots:
        raise RoleEngineError(f'{scenario.source}: mobile_robots: the role nodes need at least one robot')
    team = []
    for robot in robots:
        params = robot.params
        robot_type = RobotType(params.type_name, float(params.radius), inflation_margin=inflation_margin,
                               max_linear_velocity=float(params.limits.max_linear_velocity),
                               max_angular_velocity=float(params.limits.max_angular_velocity))
        team.append(TeamMember(robot.name, robot_type, tuple(params.color), float(params.height)))
    return team


class TypedGPEvaluator:
    """Evaluator for :func:`.qualification.qualification_matrix`: GP inference with each type's settings.

    Algorithm 3 lines 7-19 as ``experiments.GPProcessRoleEvaluator``, but the speed limit
    (Eq. 22) depends on the robot type, so there is one planner per type.
    """

    def __init__(self, task: FormationTask):
        self.task = task
        self._planners: dict[str, GPPlanner] = {}

    def __call__(self, agent, role, initial: np.ndarray, robot_env: RobotEnvironment):
        name = robot_env.robot_type.name
        if name not in self._planners:
            self._planners[name] = GPPlanner(self.task.gp_config(robot_env.robot_type), robot_env.sdf)
        result = self._planners[name].plan(initial, self.task.total_time)
        return ProcessRoleEvaluation(result.trajectory, result.term_costs['gp_prior'], result.iterations)
