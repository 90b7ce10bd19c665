"""scripts/orchestrate with SROS2 requested where the middleware has no DDS-Security (the PyPI wheels).

Enforce, from the command line or the experiment file: one line saying what blocks, exit 6, no
traceback, and no node started. (On an apt install with DDS-Security the probe succeeds: skipped.)
"""
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from collab_tools.core.sros2_policy import NodeAccess
from collab_tools.orchestration.security import EXIT_SECURITY_UNAVAILABLE, middleware_can_secure
from collab_tools.sros2_keystore import Keystore

WORKSPACE = Path(__file__).resolve().parents[2]


@pytest.fixture(scope='module')
def keystore(tmp_path_factory):
    able, _reason = middleware_can_secure()
    if able:
        pytest.skip('this middleware has DDS-Security: scripts/orchestrate would run secured')
    store = Keystore(tmp_path_factory.mktemp('keystore'))
    store.write([NodeAccess('/orchestrator', subscribe={'/*'}), NodeAccess('/scripted_driver', publish={'/rosout'})],
                None)
    return store


def orchestrate(experiment: Path, run_dir: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'orchestrate'), str(experiment),
                           '--run-dir', str(run_dir), *args], capture_output=True, text=True, timeout=120)


def test_enforce_on_the_wheels_exits_6_with_one_line_and_starts_nothing(keystore, config_dir, tmp_path):
    experiment = {'name': 'secured', 'timeout': 10, 'until': {'seconds': 1.0},
                  'nodes': [{'package': 'collab_tools', 'executable': 'scripted_driver', 'name': 'scripted_driver',
                             'parameters': [{'plan_file': str(config_dir / 'plans' / 'demo_plan.yaml')}]}]}
    from_cli = tmp_path / 'from_cli.yaml'
    from_cli.write_text(yaml.safe_dump(experiment))
    from_file = tmp_path / 'from_file.yaml'
    from_file.write_text(yaml.safe_dump({**experiment, 'security': {'keystore': str(keystore.root)}}))
    for path, args in ((from_cli, ('--security-keystore', str(keystore.root))), (from_file, ())):
        run_dir = tmp_path / path.stem
        result = orchestrate(path, run_dir, *args)
        assert result.returncode == EXIT_SECURITY_UNAVAILABLE, result.stdout + result.stderr
        errors = [line for line in result.stderr.splitlines() if line.strip()]
        assert len(errors) == 1, result.stderr
        assert 'Enforce requested but the middleware cannot enforce it' in errors[0]
        assert 'DDS-Security' in errors[0] and 'nothing was started' in errors[0]
        assert 'Traceback' not in result.stdout + result.stderr
        assert not (run_dir / 'logs').exists(), 'a node was started'
