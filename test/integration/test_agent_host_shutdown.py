"""schema_agent_host stops cleanly (exit 0, no traceback, no SIGSEGV) when SIGINT reaches it at
any moment: while it waits for the recorder, during the search, after the coalition is set up,
and -- as at the end of a two-host run -- the helpers' host right after the leader's host exited.

The crash this guards against is a race in rclpy's signal handling: on SIGINT, rclpy's signal
thread triggers every executor's SIGINT guard condition from a list it reads without a lock; the
main thread, woken, tears the executor down, which frees that guard condition and the list; a
signal thread preempted in between then touches freed memory (seen as exit -11, rarely, on a busy
machine). To make the race certain instead of rare, the hosts run with a fault injector
(LD_PRELOAD, compiled here) that keeps every thread but the main one 0.3 s in
``rcl_trigger_guard_condition`` after the real call: the signal thread lingers exactly where it
was preempted in the failing runs. Without the fix (joining that thread before the tear-down)
most stops below end with exit -11.
"""

import shutil
import subprocess
import time

import pytest
import yaml

from coalition_interfaces.msg import AgentStatus
from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec
from coalition_agents.core.sim_scenarios import agent_parameter_file

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
STATUS = 'coalition_interfaces/msg/AgentStatus'

SLOW_SIGNAL_THREAD = r'''
#define _GNU_SOURCE
#include <dlfcn.h>
#include <sys/syscall.h>
#include <unistd.h>

typedef int (*trigger_fn)(void *);

/* rcl's function, then a pause when called off the main thread (rclpy's signal thread). */
int rcl_trigger_guard_condition(void * guard_condition)
{
  static trigger_fn real = NULL;
  if (real == NULL) {
    real = (trigger_fn)dlsym(dlopen("librcl.so", RTLD_LAZY | RTLD_NOLOAD), "rcl_trigger_guard_condition");
  }
  int ret = real(guard_condition);
  if (syscall(SYS_gettid) != getpid()) {
    usleep(300000);
  }
  return ret;
}
'''


@pytest.fixture(scope='module')
def slow_signal_thread(tmp_path_factory) -> dict:
    """The environment that preloads the fault injector (see the module docstring)."""
    compiler = shutil.which('cc') or shutil.which('gcc')
    if compiler is None:
        pytest.skip('no C compiler to build the fault injector')
    build = tmp_path_factory.mktemp('slow_signal_thread')
    source, library = build / 'slow_signal_thread.c', build / 'slow_signal_thread.so'
    source.write_text(SLOW_SIGNAL_THREAD)
    subprocess.run([compiler, '-shared', '-fPIC', '-O2', '-o', str(library), str(source), '-ldl'], check=True)
    return {'LD_PRELOAD': str(library), 'PYTHONFAULTHANDLER': '1'}


def files(config_dir):
    coalitions = config_dir / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml')}


def wait_for(condition, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.05)


def assert_clean(process, code: int) -> None:
    log = process.log_path.read_text(errors='replace')
    assert code == 0, f'{process.name}: exit {code}\n{log[-3000:]}'
    assert 'Traceback' not in log and 'Fatal Python error' not in log, log[-3000:]


def test_sigint_at_any_moment_stops_the_agent_host_cleanly(session, config_dir, tmp_path, slow_signal_thread):
    agents = tmp_path / 'agents.yaml'
    agents.write_text(yaml.safe_dump(agent_parameter_file(
        {**files(config_dir), 'task': 'none', 'team_task': 'navigation', 'search_time': 3.0, 'seed': 7},
        {LEADER: {'task': 'navigation'}})))
    node = session.observer.node

    def host(name: str, robots: list[str], parameters_file=agents, **parameters):
        return session.start(NodeSpec('coalition_agents', 'schema_agent_host', name=name, env=slow_signal_thread,
                                      parameters=[{'robots': robots, 'agent_parameters': str(parameters_file),
                                                   **parameters}]))

    def hosting(process) -> bool:
        return 'hosting 3 schema_agent nodes' in process.log_path.read_text(errors='replace')

    # 1. While it waits for a recorder that never comes (before any agent exists).
    waiting = host('host_waiting', [LEADER, HELPER, BYSTANDER], wait_for_recorder=60.0)
    wait_for(lambda: node.count_publishers('/coalition/channel') > 0, 'the host to offer the agent channel')
    assert_clean(waiting, session.stop(waiting.name))

    scenario = config_dir / 'scenarios' / 'coalition_three_robots.yaml'
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))

    # 2. During the search: the agents were just created and reason.
    searching = host('host_searching', [LEADER, HELPER, BYSTANDER])
    wait_for(lambda: hosting(searching), 'the agents to start')
    assert_clean(searching, session.stop(searching.name))

    # 3. Once the leader's search is over (its coalition set up, the helper committed).
    settled = host('host_settled', [LEADER, HELPER, BYSTANDER])
    session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=60.0,
                             predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    assert_clean(settled, session.stop(settled.name))

    # 4. As at the end of a two-host run: the leader's host exits on its own, then the helpers'
    # host is stopped at once.
    split = tmp_path / 'agents_split.yaml'
    split.write_text(yaml.safe_dump(agent_parameter_file(
        {**files(config_dir), 'task': 'none', 'team_task': 'navigation', 'search_time': 3.0, 'seed': 7},
        {LEADER: {'task': 'navigation', 'exit_when_done': True}})))
    helpers = host('host_helpers', [HELPER, BYSTANDER], split, linger=0.5)
    leaders = host('host_leader', [LEADER], split, linger=0.5)
    assert_clean(leaders, session.wait_for_exit(leaders.name, timeout=60.0))
    assert_clean(helpers, session.stop(helpers.name))
