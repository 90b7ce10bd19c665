"""schema_agent_host: several schema_agent nodes in one process, like an rclcpp component container.

Why: the Fig. 9 column runs up to 20 agents. Twenty rclpy processes on this 2-core machine cost
~20 interpreters, 20 DDS participants and their discovery traffic, and the operating system's
scheduling between them -- start-up alone takes tens of seconds and their contention, not the
algorithm, would dominate the measured search time. As in an rclcpp component container, every
agent here is still its own, unchanged :class:`~.schema_agent_node.SchemaAgentNode` with its own
name, parameters, publishers and subscriptions on the real topics (``/coalition/channel``,
``/<robot>/coalition``, the bridge's sensor topics and services); only the process, the DDS
participant and the executor are shared. One executor runs every node's callbacks; each node's
callbacks stay mutually exclusive (its default callback group), so an agent sees its events one
at a time, as in its own process. ``executor``: ``single`` (default) -- rclpy's single-threaded
executor: under the GIL threads add no parallelism, and the multi-threaded executor's per-callback
overhead (futures, thread hand-over) made the agents fall behind a burst of channel messages;
``multi`` -- a multi-threaded executor with one thread per agent.

With the single-threaded executor the agents' deferred work -- their reasoning slices and the
channel messages waiting for them -- runs through ONE :class:`~.core.cooperative_work.CooperativeWork`
queue, ``work_slice`` (wall s) per executor cycle, round robin: every cycle still serves all
inboxes, timers and sensor reports, so a COMMIT_REQUEST or an ACK waits for at most one short
cycle instead of every agent's reasoning.

Parameters:

* ``robots`` (string array, required): the robots to host; agent ``<robot>`` becomes the node
  ``<node_prefix><robot>``.
* ``agent_parameters`` (path, required): a ROS 2 parameter file for the hosted nodes, read by
  rcl as a ``--params-file`` of each node: ``/**`` entries for every agent, ``<node_prefix><robot>``
  entries per agent (``robot`` is set by the host).
* ``node_prefix`` (default ``schema_agent_``).
* ``wait_for_recorder`` (s, default 0): offer ``/coalition/channel`` and the hosted robots'
  inboxes ``/coalition/channel/<robot>`` and wait up to this long for a subscriber of each (the
  bag recorder) before creating the agents, so the whole search is recorded.
* ``share_solution_spaces`` (default true): the hosted agents share one solution-space cache
  per schema library and costs file (:class:`~.core.solution_space.SolutionSpaceCache`): robots
  of equal capabilities reuse each other's generated spaces instead of generating them again.
* ``executor`` (``single`` | ``multi``, default single) and ``work_slice`` (wall s, default 0.01):
  see above.
* ``linger`` (s, default 1.0): once every hosted agent with ``exit_when_done`` is done, keep
  spinning this long (wall clock) so the last messages reach the recorder, then exit 0. Without
  any such agent the host spins until shutdown.

A hosted node that cannot start (bad parameters) stops the host with exit code 2 and the
node's message, as a schema_agent process would.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node

from collab_tools.node_support import ConfigurationError, declare as declare_parameter

from .core.cooperative_work import CooperativeWork
from .schema_agent_node import SchemaAgentNode


class _NodeOptions(Node):
    """Gives the hosted node its own command-line arguments (name remap, parameter file) instead of
    the process's: cooperative ``super().__init__`` puts this between SchemaAgentNode and Node."""

    node_arguments: list[str] = []
    node_context = None

    def __init__(self, node_name: str, **kwargs):
        super().__init__(node_name, cli_args=self.node_arguments, use_global_arguments=False,
                         context=self.node_context, **kwargs)


def hosted_agent(node_name: str, robot: str, parameter_file: Path, use_sim_time: bool, context=None,
                 solution_caches: dict | None = None, work: CooperativeWork | None = None) -> SchemaAgentNode:
    """A SchemaAgentNode named ``node_name`` reading its parameters from ``parameter_file``
    (``solution_caches``, ``work``: shared between the hosted agents, see SchemaAgentNode)."""
    arguments = ['--ros-args', '-r', f'__node:={node_name}', '--params-file', str(parameter_file),
                 '-p', f'robot:={robot}', '-p', f'use_sim_time:={"true" if use_sim_time else "false"}']
    node_class = type(f'HostedSchemaAgent_{robot}', (SchemaAgentNode, _NodeOptions),
                      {'node_arguments': arguments, 'node_context': context,
                       'shared_solution_caches': solution_caches, 'shared_work': work})
    return node_class()


class AgentHost(Node):
    def __init__(self):
        super().__init__('schema_agent_host')
        for name, default, description in (
                ('robots', [''], 'robots whose schema_agent this process hosts'),
                ('agent_parameters', '', 'ROS 2 parameter file of the hosted schema_agent nodes'),
                ('node_prefix', 'schema_agent_', 'hosted node name = prefix + robot'),
                ('linger', 1.0, 'wall s to keep spinning once every exit_when_done agent is done, >= 0'),
                ('wait_for_recorder', 0.0, 'wall s to wait for a subscriber of the agent channel (the bag '
                                           'recorder) before the agents start; 0 = do not wait'),
                ('executor', 'single', "'single' (single-threaded executor) or 'multi' (one thread per agent)"),
                ('work_slice', 0.01, 'wall s, > 0: how long the agents\' shared deferred work (reasoning, '
                                     'channel messages for the agents) runs per executor cycle (executor single)'),
                ('share_solution_spaces', True, 'one solution-space cache for the hosted agents (robots of equal '
                                                'capabilities reuse generated spaces)')):
            declare_parameter(self, name, default, description)
        robots = self.get_parameter('robots').value
        if not isinstance(robots, (list, tuple)) or not robots or not all(isinstance(r, str) and r for r in robots):
            raise ConfigurationError(f'parameter robots: a non-empty list of robot names (got {robots!r})')
        if len(set(robots)) != len(robots):
            raise ConfigurationError(f'parameter robots: {robots!r} names a robot twice')
        path = self.get_parameter('agent_parameters').value
        if not isinstance(path, str) or not path or not Path(path).is_file():
            raise ConfigurationError(f'parameter agent_parameters: no such file {path!r}')
        linger = self.get_parameter('linger').value
        if isinstance(linger, bool) or not isinstance(linger, (int, float)) or linger < 0:
            raise ConfigurationError(f'parameter linger: must be a number >= 0 (got {linger!r})')
        self.linger = float(linger)
        self.wait_for_recorder = float(self.get_parameter('wait_for_recorder').value or 0.0)
        self.robots, self.parameter_file = list(robots), Path(path)
        self.prefix = str(self.get_parameter('node_prefix').value)
        self.executor_kind = self.get_parameter('executor').value
        if self.executor_kind not in ('single', 'multi'):
            raise ConfigurationError(f"parameter executor: must be 'single' or 'multi' (got {self.executor_kind!r})")
        work_slice = self.get_parameter('work_slice').value
        if isinstance(work_slice, bool) or not isinstance(work_slice, (int, float)) or not work_slice > 0:
            raise ConfigurationError(f'parameter work_slice: must be a number > 0 (got {work_slice!r})')
        self.work: CooperativeWork | None = None
        if self.executor_kind == 'single':  # threads: each agent keeps its own queue
            trigger = self.create_guard_condition(lambda: self.work.run())
            self.work = CooperativeWork(trigger.trigger, float(work_slice), self._step_failed)
        self.agents: list[SchemaAgentNode] = []
        self.share_solution_spaces = bool(self.get_parameter('share_solution_spaces').value)

    def wait_for_channel_recorder(self) -> bool:
        """Offer the agent channel and wait until someone (the recorder) subscribes, so that the
        first requests of the search are recorded too (a recorder subscribes only to offered topics)."""
        if self.wait_for_recorder <= 0:
            return True
        from coalition_interfaces.msg import AgentMessage, AgentMessageBatch
        from .agent_channel import DEFAULT_TOPIC, inbox_topic
        topics = [DEFAULT_TOPIC] + [inbox_topic(robot) for robot in self.robots]
        # The inboxes carry batches, the shared topic single messages (agent_channel).
        publishers = [self.create_publisher(AgentMessage if topic == DEFAULT_TOPIC else AgentMessageBatch, topic, 10)
                      for topic in topics]
        deadline = time.monotonic() + self.wait_for_recorder
        while any(p.get_subscription_count() == 0 for p in publishers) and time.monotonic() < deadline:
            time.sleep(0.05)
        missing = [topic for topic, p in zip(topics, publishers) if p.get_subscription_count() == 0]
        ok = not missing
        if not ok:
            self.get_logger().warning(f'nobody subscribed to {", ".join(missing)} within {self.wait_for_recorder:g} s; '
                                      'starting the agents anyway')
        time.sleep(0.3)  # the recorder opens the topic in the bag before the first message
        return ok

    def start_agents(self) -> None:
        use_sim_time = bool(self.get_parameter('use_sim_time').value)
        prefix, path = self.prefix, self.parameter_file
        caches: dict | None = {} if self.share_solution_spaces else None
        for robot in self.robots:
            try:
                self.agents.append(hosted_agent(f'{prefix}{robot}', robot, path, use_sim_time, solution_caches=caches,
                                                work=self.work))
            except ConfigurationError as error:
                self.destroy_agents()
                raise ConfigurationError(f'agent {prefix}{robot}: {error}') from None
        self.get_logger().info(f'hosting {len(self.agents)} schema_agent nodes: '
                               + ', '.join(a.get_name() for a in self.agents))

    def _step_failed(self, step, exc: Exception) -> None:
        self.get_logger().error(f'{getattr(step, "__qualname__", step)} failed: {type(exc).__name__}: {exc}')

    def finishing(self) -> list[SchemaAgentNode]:
        return [agent for agent in self.agents if agent.exit_when_done]

    def destroy_agents(self) -> None:
        for agent in self.agents:
            agent.destroy_node()
        self.agents.clear()


def main(args=None) -> int:
    rclpy.init(args=args)
    try:
        host = AgentHost()
        host.wait_for_channel_recorder()
        host.start_agents()
    except ConfigurationError as error:
        rclpy.logging.get_logger('schema_agent_host').fatal(f'cannot start: {error}')
        rclpy.try_shutdown()
        return 2
    executor = (SingleThreadedExecutor() if host.executor_kind == 'single'
                else MultiThreadedExecutor(num_threads=len(host.agents) + 1))
    for node in (host, *host.agents):
        executor.add_node(node)
    waiting = host.finishing()
    try:
        while rclpy.ok() and (not waiting or not all(agent.finished.done() for agent in waiting)):
            executor.spin_once(timeout_sec=0.1)
        if waiting:
            host.get_logger().info(f'every finishing agent is done; lingering {host.linger:g} s')
            end = time.monotonic() + host.linger
            while rclpy.ok() and time.monotonic() < end:
                executor.spin_once(timeout_sec=0.05)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:  # SIGINT mid-publish (see collab_tools.node_support.run)
        if rclpy.ok():
            raise
    finally:
        executor.shutdown()
        host.destroy_agents()
        host.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
