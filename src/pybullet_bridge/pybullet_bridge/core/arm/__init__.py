"""Robot arms that move cubes (the ``arms`` scenario section) and their pick-and-place task.

An arm is a fixed-base URDF from pybullet_data standing on a pedestal. A pick-and-place task
runs as a state machine advanced in the scene's step hooks, so it lives in simulated time and
is as reproducible as the physics. Modules, by concern (pure ones need no simulator):

==================  =====  =====================================================================
module              pure   concern
==================  =====  =====================================================================
``models``          yes    catalogue of arm models (URDF, joints, tool point, home, reach)
``definition``      yes    an arm as the scenario defines it, reach geometry, ``arms`` parsing
``timing``          yes    the cubic time law and segment durations from the arm's limits
``task``            yes    the task the adapter sees: phases, progress, :class:`Outcome`
``requests``        yes    checking a request against the scene; the pixel test for the spot
``state_machine``   yes    segment by segment progress, timeouts, cancel, failure recovery
``outcome``         yes    judging where the object ended; the result message
``kinematics``      no     a loaded arm in pybullet: joints, tool pose, inverse kinematics
``segments``        no     joint moves, straight tool moves and holds that drive the motors
``planning``        no     key poses by IK and the segment list of a task
``recovery``        no     segments that end a task early (put back, drop, go home)
``gripper``         no     fingers and the fixed constraint that holds a grasped cube
``simulation``      no     :class:`~.simulation.SimulatedArm`: spawns the arm and runs its task
==================  =====  =====================================================================

Task phases: approach -> grasp -> lift -> transport -> place -> release -> retreat. Each motion
segment may run at most its planned duration plus ``phase_timeout`` seconds of simulated time;
a segment that does not converge ends the task with EXECUTION_FAILED and a message naming the
step and the remaining error, instead of hanging.

Simulated execution failure (SGCM paper, Sec. III: with probability p_fail an action fails and
is "an empty action"): once per task, before the arm moves, a draw from the arm's own seeded
generator decides whether the grasp slips. A slipping grasp makes the same motion without the
constraint (and without squeezing the fingers), so the object stays where it was; the outcome
is EXECUTION_FAILED. Rejected goals and goals without a free spot draw nothing.

Cancel: while the arm holds the object it carries it back to where it was picked and sets it
down there, then goes home; before the grasp it just goes home. Once the object is released
the cancel is refused (only the retreat is left). A canceled task ends with ABORTED, as does a
task whose scene is reset.

This package's ``__init__`` imports only the pure modules, so reading a scenario's arms needs
no simulator.
"""
from .definition import Arm, ArmLimits, parse_arms
from .models import ARM_MODELS, ArmModel
from .task import PHASES, Outcome, PickPlaceTask

__all__ = ['ARM_MODELS', 'PHASES', 'Arm', 'ArmLimits', 'ArmModel', 'Outcome', 'PickPlaceTask', 'parse_arms']
