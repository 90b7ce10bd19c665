"""schema_agent_host: several schema_agent nodes in one process, like an rclcpp component container.

Why: the Fig. 9 column runs up to 20 agents. Twenty rclpy processes on this 2-core machine cost ~20 interpreters, 20
DDS participants and their discovery traffic, and the operating system's scheduling between them -- start-up alone
takes tens of seconds and their contention, not the algorithm, would dominate the measured search time. As in an rclcpp
component container, every agent here is still its own, unchanged :class:`~.schema_agent_node.SchemaAgentNode` with its
own name, parameters, publishers and subscriptions on the real topics (``/<robot>/coalition``, the bridge's sensor
topics and services); only the process, the DDS participant, the executor and the channel's endpoints are shared: ONE
:class:`~.transport.channel_hub.ChannelHub` (one publisher and subscription of ``<team>/coalition/bundles``, one timer)
serves every hosted agent -- not one subscription and timer per agent (``executor: multi``: each agent has its own).
One executor runs every node's callbacks; each node's callbacks stay mutually exclusive (its default callback group),
so an agent sees its events one at a time, as in its own process. ``executor``: ``single`` (default) -- rclpy's
single-threaded executor: under the GIL threads add no parallelism, and the multi-threaded executor's per-callback
overhead (futures, thread hand-over) made the agents fall behind a burst of channel messages; ``multi`` -- a
multi-threaded executor with one thread per agent.

With the single-threaded executor the agents' deferred work -- their reasoning slices and the channel messages waiting
for them -- runs through ONE :class:`~.core.cooperative_work.CooperativeWork` queue, ``work_slice`` (wall s) per
executor cycle, round robin: every cycle still serves the channel, timers and sensor reports, so a COMMIT_REQUEST or an
ACK waits for at most one short cycle instead of every agent's reasoning.

Each hosted agent is a :class:`~.schema_agent_node.SchemaAgentNode` named ``schema_agent`` in its robot's namespace
under the host's (``/<robot>/schema_agent`` for a host in ``/``), built with its own arguments (no subclass per agent):
the host's own ``--params-file`` arguments (so the agents' parameters come with the host's: ``/**`` entries for every
agent, ``/**/<robot>/schema_agent`` entries per agent, :func:`~.core.sim_scenarios.agent_parameter_file`; an agent
ignores the host's parameters and the host the agents'), then ``agent_parameters`` if set, the host's remapping rules
(e.g. ``/clock``; not its name or namespace), ``use_sim_time`` as the host's and ``team_namespace`` when the host's is
set. The host's ``-p`` values stay its own.

Parameters (all read-only: they shape the process at start-up):
* ``robots`` (string array, required): the robots to host.
* ``agent_parameters`` (path, optional): one more ROS 2 parameter file for the hosted nodes only,
  after the host's own parameter files (a later file's value wins).
* ``team_namespace`` (default '': the host's namespace): where the channel lives.
* ``wait_for_recorder`` (s, default 0): offer ``<team>/coalition/channel``, ``.../batches`` and ``.../bundles``, wait
  up to this long for the recorder to subscribe to all three before creating the agents.
* ``share_solution_spaces`` (default true): the hosted agents share one solution-space cache
  per schema library and costs file (:class:`~.core.solution_space.SolutionSpaceCache`): robots
  of equal capabilities reuse each other's generated spaces instead of generating them again.
* ``executor`` (``single`` | ``multi``, default single), ``work_slice`` (wall s, 0.01): see above;
  ``COALITION_HOST_PROFILE`` in the environment: a profile of the spin loop (:mod:`.host_runtime`).
* ``linger`` (s, default 1.0): once every hosted agent with ``exit_when_done`` is done, keep
  spinning this long (wall clock) so the last messages reach the recorder, then exit 0. Without
  any such agent the host spins until shutdown.

A hosted node that cannot start (bad parameters) stops the host with exit code 2 and the
node's message, as a schema_agent process would.
"""
from __future__ import annotations

import sys
import time

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from collab_tools import qos
from collab_tools.names import TeamNode, check_robot_name, join
from collab_tools.core.input_files import yaml_file_problem
from collab_tools.core.settings import Setting, SettingsSchema
from collab_tools.node_support import ConfigurationError, stop_signal_handling, stop_under_way
from collab_tools.parameters import NodeParameters

from .transport.agent_channel import CHANNEL_TOPIC, batch_topic, bundle_topic
from .transport.channel_hub import ChannelHub
from .core.cooperative_work import CooperativeWork
from .host_runtime import profiled, tune_collector
from .schema_agent_node import SchemaAgentNode

#: remapping targets that rename or move a node: the host's own, never forwarded to its agents
_NODE_RULES = ('__node', '__name', '__ns')


def forwarded_remappings(argv: list[str]) -> list[str]:
    """The ``-r from:=to`` rules of the process's ROS arguments that its hosted agents must get
    too (``/clock:=/sim1/clock``), as ``['-r', rule, ...]``: not the rules that name or move the
    host itself (``__node``, ``__ns``) nor those addressed to another node (``node:from:=to``)."""
    forwarded, ros_args, index = [], False, 0
    while index < len(argv):
        token = argv[index]
        if token == '--ros-args':
            ros_args = True
        elif token == '--':
            ros_args = False
        elif ros_args and token in ('-r', '--remap') and index + 1 < len(argv):
            rule = argv[index + 1]
            index += 1
            source = rule.split(':=', 1)[0]
            target_node, _, name = source.rpartition(':') if ':' in source else ('', '', source)
            if ':=' in rule and name not in _NODE_RULES and target_node in ('', 'schema_agent'):
                forwarded += ['-r', rule]
        index += 1
    return forwarded


def forwarded_parameter_files(argv: list[str]) -> list[str]:
    """The ``--params-file`` arguments of the process's ROS arguments, as ``['--params-file', path, ...]``
    in their order: the hosted agents read them too, so their parameters need no file of their own."""
    forwarded, ros_args, index = [], False, 0
    while index < len(argv):
        token = argv[index]
        if token == '--ros-args':
            ros_args = True
        elif token == '--':
            ros_args = False
        elif ros_args and token == '--params-file' and index + 1 < len(argv):
            forwarded += ['--params-file', argv[index + 1]]
            index += 1
        index += 1
    return forwarded


def _robots_problem(robots: list[str]) -> str | None:
    for robot in robots:
        problem = check_robot_name(robot)
        if problem:
            return problem
    if len(set(robots)) != len(robots):
        return f'names a robot twice (got {robots!r})'
    return None


#: The host's own parameters (all read-only: they shape the process at start-up).
HOST_SETTINGS = SettingsSchema(
    Setting('robots', [''], 'robots whose schema_agent this process hosts (node <host namespace>/<robot>/schema_agent '
            'each)', required=True, check=_robots_problem),
    Setting('agent_parameters', '', "optional: one more ROS 2 parameter file for the hosted schema_agent nodes only, "
            "read after the host's own parameter files (which the agents read too); '' = none", check=yaml_file_problem),
    Setting('linger', 1.0, 'wall s to keep spinning once every exit_when_done agent is done', low=0.0, high=3600.0),
    Setting('wait_for_recorder', 0.0, 'wall s to wait for a subscriber of the agent channel (the bag recorder) '
            'before the agents start; 0 = do not wait', low=0.0, high=3600.0),
    Setting('executor', 'single', "'single' (single-threaded executor) or 'multi' (one thread per agent)",
            choices=('single', 'multi')),
    Setting('work_slice', 0.01, "wall s: how long the agents' shared deferred work (reasoning, channel messages for "
            'the agents) runs per executor cycle (executor single)', low=0.0, low_open=True, high=1.0),
    Setting('share_solution_spaces', True, 'one solution-space cache for the hosted agents (robots of equal '
            'capabilities reuse generated spaces)'),
)


class AgentHost(Node):
    def __init__(self, argv: list[str] | None = None):
        super().__init__('schema_agent_host')
        self.params = NodeParameters(self)
        self.names = TeamNode(self, self.params)
        values = self.params.declare_schema(HOST_SETTINGS)
        self.robots = values['robots']
        self.parameter_file = values['agent_parameters']
        self.linger = values['linger']
        self.wait_for_recorder = values['wait_for_recorder']
        self.executor_kind = values['executor']
        work_slice = values['work_slice']
        self.share_solution_spaces = values['share_solution_spaces']
        self.argv = list(sys.argv if argv is None else argv)
        self.work: CooperativeWork | None = None
        if self.executor_kind == 'single':  # threads: each agent keeps its own queue
            trigger = self.create_guard_condition(lambda: self.work.run())
            self.work = CooperativeWork(trigger.trigger, work_slice, self._step_failed)
        self.agents: list[SchemaAgentNode] = []
        self.hub: ChannelHub | None = None

    def wait_for_channel_recorder(self) -> bool:
        """Offer the agent channel and wait until someone (the recorder) subscribes, so that the
        first requests of the search are recorded too (a recorder subscribes only to offered topics)."""
        if self.wait_for_recorder <= 0:
            return True
        from coalition_interfaces.msg import AgentMessage, AgentMessageBatch, AgentMessageBundle
        channel = self.names.team(CHANNEL_TOPIC)
        # The shared topic carries single messages, the batch topic single batches (tools), the
        # bundle topic every batch the agents send (agent_channel).
        types = {channel: AgentMessage, batch_topic(channel): AgentMessageBatch, bundle_topic(channel): AgentMessageBundle}
        topics = list(types)
        publishers = [self.create_publisher(types[topic], topic, qos.RELIABLE) for topic in topics]
        def recorded(topic: str, publisher) -> bool:
            # Agent processes subscribe to the channel topics too: only another node counts.
            return publisher.get_subscription_count() > 0 and any(
                not info.node_name.startswith('schema_agent') for info in self.get_subscriptions_info_by_topic(topic))
        deadline = time.monotonic() + self.wait_for_recorder
        while not all(recorded(t, p) for t, p in zip(topics, publishers)) and time.monotonic() < deadline:
            time.sleep(0.05)
        missing = [topic for topic, p in zip(topics, publishers) if not recorded(topic, p)]
        ok = not missing
        if not ok:
            self.get_logger().warning(f'nobody subscribed to {", ".join(missing)} within {self.wait_for_recorder:g} s; '
                                      'starting the agents anyway')
        time.sleep(0.3)  # the recorder opens the topic in the bag before the first message
        return ok

    def agent_arguments(self) -> tuple[list[str], list[Parameter]]:
        """(cli_args, parameter_overrides) of every hosted agent (see the module docstring)."""
        files = forwarded_parameter_files(self.argv)
        if self.parameter_file:
            files += ['--params-file', self.parameter_file]
        cli_args = ['--ros-args', *files, *forwarded_remappings(self.argv)]
        overrides = [Parameter('use_sim_time', value=bool(self.get_parameter('use_sim_time').value))]
        if self.get_parameter('team_namespace').value:
            overrides.append(Parameter('team_namespace', value=self.names.team_namespace))
        return cli_args, overrides

    def start_agents(self) -> None:
        cli_args, overrides = self.agent_arguments()
        caches: dict | None = {} if self.share_solution_spaces else None
        channel = self.names.team(CHANNEL_TOPIC)
        # Before any agent's status publisher: a teammate seeing the status can send it batches.
        if self.executor_kind == 'single':  # threads: each agent's channel in its own callback group
            self.hub = ChannelHub(self, channel, batch_topic(channel))
        for robot in self.robots:
            namespace = join(self.get_namespace(), robot)
            try:
                self.agents.append(SchemaAgentNode(namespace, cli_args=cli_args, parameter_overrides=overrides,
                                                   context=self.context, solution_caches=caches, work=self.work,
                                                   hub=self.hub))
            except ConfigurationError as error:
                self.destroy_agents()
                raise ConfigurationError(f'agent {namespace}/schema_agent: {error}') from None
        self.get_logger().info(f'hosting {len(self.agents)} schema_agent nodes: '
                               + ', '.join(a.get_fully_qualified_name() for a in self.agents))

    def _step_failed(self, step, exc: Exception) -> None:
        self.get_logger().error(f'{getattr(step, "__qualname__", step)} failed: {type(exc).__name__}: {exc}')

    def finishing(self) -> list[SchemaAgentNode]:
        return [agent for agent in self.agents if agent.exit_when_done]

    def destroy_agents(self) -> None:
        for agent in self.agents:
            agent.destroy_node()
        self.agents.clear()
        if self.hub is not None:
            self.hub.destroy()
            self.hub = None


def _tear_down(host: AgentHost | None, executor=None) -> None:
    """Stop the executor (and its worker threads), then destroy the agents, the host and the context.
    First join rclpy's signal thread: it may still be triggering the executor's SIGINT guard
    condition that executor.shutdown() frees (SIGSEGV at the end of runs; see stop_signal_handling)."""
    stop_signal_handling()
    if executor is not None:
        executor.shutdown()
        pool = getattr(executor, '_executor', None)  # MultiThreadedExecutor: callbacks still queued
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
    if host is not None:
        host.destroy_agents()
        host.destroy_node()
    rclpy.try_shutdown()


def main(args=None) -> int:
    rclpy.init(args=args)
    host = None
    try:
        host = AgentHost(args)
        host.wait_for_channel_recorder()
        host.start_agents()
    except (ConfigurationError, ParameterException) as error:
        rclpy.logging.get_logger('schema_agent_host').fatal(f'cannot start: {error}')
        _tear_down(host)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException, RuntimeError) as error:
        if isinstance(error, RuntimeError) and not stop_under_way():
            raise
        _tear_down(host)  # stopped while starting (e.g. waiting for the recorder): a normal stop
        return 0
    executor = None
    try:
        executor = (SingleThreadedExecutor() if host.executor_kind == 'single'
                    else MultiThreadedExecutor(num_threads=len(host.agents) + 1))
        for node in (host, *host.agents):
            executor.add_node(node)
        # The start-up heap frozen, fewer young collections (host_runtime). Here, not before the
        # executor exists: collecting the start-up heap takes a while, and a SIGINT that lands in
        # rclpy's Executor constructor leaves an executor whose __del__ prints a traceback.
        tune_collector()
        waiting = host.finishing()
        with profiled(host.get_name()):  # COALITION_HOST_PROFILE=<dir> only (host_runtime)
            while rclpy.ok() and (not waiting or not all(agent.finished.done() for agent in waiting)):
                executor.spin_once(timeout_sec=0.1)
        if waiting:
            host.get_logger().info(f'every finishing agent is done; lingering {host.linger:g} s')
            end = time.monotonic() + host.linger
            while rclpy.ok() and time.monotonic() < end:
                executor.spin_once(timeout_sec=0.05)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:  # SIGINT mid-publish or mid-take (see collab_tools.node_support.run)
        if not stop_under_way():
            raise
    finally:
        _tear_down(host, executor)
    return 0


if __name__ == '__main__':
    sys.exit(main())
