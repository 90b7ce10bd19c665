#!/usr/bin/env python3
"""Create an SROS2 keystore for an experiment: a CA, one enclave per node, permissions for its topics.

    scripts/tools/sros2_keystore.py config/experiments/demo_mobile.yaml --keystore ~/keystores/demo
    scripts/tools/sros2_keystore.py --policy ~/keystores/demo/policy.xml --keystore ~/keystores/demo2
    scripts/tools/sros2_keystore.py --check ~/keystores/demo

With an experiment file, the experiment is run once unsecured (as scripts/orchestrate runs it) and
the ROS graph is watched while it runs: what each node publishes, subscribes, serves and calls --
its own declarations, nothing listed by hand -- becomes its permissions (deny by default). The
enclave of a node is its fully qualified name (``/burger1/role_player``); ``/orchestrator`` (the
orchestration's observer) may read every topic and call every service, and ``bag_recorder`` read
every topic. The keystore's ``policy.xml`` keeps those permissions in sros2's policy format: edit it and
re-run with ``--policy``, or feed it to ``ros2 security create_permission`` on an apt install.

The layout and documents are those of ``ros2 security create_keystore / create_enclave`` (see
collab_tools.sros2_keystore), signed with the openssl command line. On an apt ROS 2 Jazzy install
the standard route is ``ros2 security``; this script makes the same keystore where sros2 is missing
(the PyPI wheels). Run the secured experiment with
``scripts/orchestrate FILE --security-keystore DIR`` (on the wheels: exit 6, the middleware
has no DDS-Security). Exit codes: 0 done, 1 the experiment failed (no keystore written) or --check
found a bad signature, 2 bad arguments or files.
"""
import argparse
import sys
import tempfile
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import _workspace  # noqa: E402  (scripts/_workspace.py: the workspace environment)

_workspace.ensure_workspace_env()

from collab_tools.core.errors import ConfigurationError  # noqa: E402
from collab_tools.core.sros2_policy import NodeAccess, access_from_graph, parse_policy  # noqa: E402
from collab_tools.orchestration.experiment import RECORDER, load_experiment, parse_node, run_experiment  # noqa: E402
from collab_tools.orchestration.security import ORCHESTRATOR_ENCLAVE  # noqa: E402
from collab_tools.sros2_keystore import Keystore, KeystoreError, verify  # noqa: E402

WATCH_PERIOD_S = 0.5


class GraphWatch:
    """Unions every node's endpoints, sampled from the session's observer while the run goes on."""

    def __init__(self):
        self.accesses: dict[str, NodeAccess] = {}
        self._stop = threading.Event()
        self._thread = None

    def start(self, session) -> None:
        names = [session.enclave(p.spec) for p in session.nodes.values()]
        observer = session.observer
        self.accesses = {name: NodeAccess(name) for name in names}

        def sample():
            while not self._stop.wait(WATCH_PERIOD_S):
                try:
                    for name in names:
                        self.accesses[name].merge(access_from_graph(name, *observer.endpoints(name)))
                except Exception:  # noqa: BLE001 - the observer closes when the run ends
                    return
        for name in names:   # at once too: a short run may end before the first period
            self.accesses[name].merge(access_from_graph(name, *observer.endpoints(name)))
        self._thread = threading.Thread(target=sample, name='graph-watch', daemon=True)
        self._thread.start()

    def stop(self) -> list[NodeAccess]:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        return list(self.accesses.values())


def standard_enclaves(recorder: str | None) -> list[NodeAccess]:
    """The orchestration's own participants: its observer, and the recorder (reads what it discovers)."""
    own = [NodeAccess(ORCHESTRATOR_ENCLAVE, publish={'/rosout', '/parameter_events'}, subscribe={'/*'},
                      request={'/*'})]
    if recorder:
        own.append(NodeAccess(recorder, publish={'/rosout', '/parameter_events'}, subscribe={'/*'},
                              reply={f'{recorder}/*'}))
    return own


def from_experiment(path: Path, keystore: Keystore, run_dir: Path | None) -> int:
    data = load_experiment(path)
    watch = GraphWatch()
    with tempfile.TemporaryDirectory(prefix='sros2_keystore_run_') as tmp:   # the run's logs: kept with --run-dir
        result = run_experiment(path.resolve(), _workspace.CONFIG_DIR, run_dir=run_dir or Path(tmp),
                                on_running=watch.start)
    accesses = watch.stop()
    if result.exit_code != 0 or not accesses:
        print(f'error: {path}: the experiment did not complete ({result.message}; exit {result.exit_code}): '
              'no keystore written', file=sys.stderr)
        return 1
    recorder = next((a.enclave for a in accesses if a.enclave.endswith('/' + RECORDER.name)), None)
    nodes = [a for a in accesses if a.enclave != recorder]
    empty = [a.enclave for a in nodes if not any(getattr(a, k) for k in NodeAccess.KINDS)]
    if empty:
        print(f"error: {path}: never saw {', '.join(empty)} in the graph: no keystore written", file=sys.stderr)
        return 1
    expected = {parse_node(n, 'node').label for n in data['nodes']}
    written = keystore.write(nodes + standard_enclaves(recorder), data.get('domain_id'))
    print(f'{keystore.root}: {len(written)} enclaves ({len(expected)} experiment nodes, the orchestrator'
          f"{', the recorder' if recorder else ''}); policy in {keystore.root / 'policy.xml'}")
    return 0


def check(keystore: Keystore) -> int:
    """Every signature verifies against the CA and every permissions document is XML; prints the enclaves."""
    if not keystore.is_valid():
        print(f'error: {keystore.root}: not an SROS2 keystore', file=sys.stderr)
        return 2
    bad = 0
    for signed in [keystore.enclaves / 'governance.p7s',
                   *(keystore.enclave_dir(e) / 'permissions.p7s' for e in keystore.enclave_names())]:
        try:
            verify(signed, keystore.ca_cert)
        except KeystoreError as error:
            bad += 1
            print(f'BAD {signed}: {error}', file=sys.stderr)
    for enclave in keystore.enclave_names():
        print(enclave)
    return 1 if bad else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('experiment', nargs='?', type=Path, help='experiment YAML file whose nodes get enclaves')
    parser.add_argument('--keystore', type=Path, help='keystore directory (created; existing CA and keys kept)')
    parser.add_argument('--policy', type=Path, help='an sros2 policy.xml instead of running an experiment')
    parser.add_argument('--domain-id', type=int, help='with --policy: the one ROS domain allowed (default: all)')
    parser.add_argument('--check', type=Path, metavar='KEYSTORE', help='verify a keystore and list its enclaves')
    parser.add_argument('--run-dir', type=Path, help="keep the experiment run's logs and bag here (default: discarded)")
    args = parser.parse_args()
    try:
        if args.check:
            return check(Keystore(args.check))
        if args.keystore is None or (args.experiment is None) == (args.policy is None):
            parser.error('give --keystore and one of: an experiment file, --policy FILE')
        if args.domain_id is not None and not 0 <= args.domain_id <= 232:
            parser.error(f'--domain-id: must be in [0, 232] (got {args.domain_id})')
        keystore = Keystore(args.keystore.expanduser())
        if args.policy:
            accesses = parse_policy(args.policy.read_text(), str(args.policy))
            keystore.write(accesses, args.domain_id)
            print(f'{keystore.root}: {len(accesses)} enclaves from {args.policy}')
            return 0
        return from_experiment(args.experiment, keystore, args.run_dir)
    except (ConfigurationError, OSError, UnicodeDecodeError) as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('\n[sros2_keystore] interrupted: the nodes were stopped, no keystore written', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
