"""The SGCM paper's experiments (``stackelberg_guidance_sgcm.txt``, Section V), one module per
table or figure, run by ``scripts/experiment`` through :data:`EXPERIMENTS`:

- :mod:`.table1`: ``sgcm-table1``, Table I (greedy vs SGCM on the ten cases of Fig. 2, with the
  centralized lower bound on rounds) and Fig. 4 (stage-wise utilities); ``--mode core`` plays the
  abstract game, ``--mode sim`` runs both arms in pybullet through the nodes and reads the bags.
- :mod:`.disturbance`: ``sgcm-disturbance``, Fig. 5 (perfect, disturbed and zero-trust followers,
  plus a random and an adversarial one).

Helpers: :mod:`.inputs` (task, cases and the options both take), :mod:`.table1_paper` (Table I beside the
paper's rows and paper_notes.md), :mod:`.case_plots` (one panel
per case), :mod:`.sim_runner` (a case through the nodes, read back from its bag),
:mod:`.report_plots` (the ``scripts/report`` plot of a Guidance bag) and :mod:`.benchmark`
(``scripts/bench sgcm``: the leader's round on the kernel and the reference path, T = 1..4, and
the MILP vs the fast stage-game solver).

Only light imports here: listing the experiments must not load their code.
"""
from dataclasses import replace

from collab_tools.experiments.api import Experiment, Option

PAPER = 'SGCM (stackelberg_guidance_sgcm)'

#: The options both experiments take (read by :func:`.inputs.task_and_cases`).
CASE_OPTIONS = (
    Option('--task', 'task file (default: config/sgcm/task.yaml)'),
    Option('--cases', 'cases file (default: config/sgcm/cases.yaml)'),
    Option('--horizon', 'override game.horizon (T)', type=int),
    Option('--only', 'run only these cases', nargs='+', metavar='CASE'),
    Option('--planner', "core mode: the leader's FSE path, kernel (compiled, the default) or reference (numpy and a "
                        'stage-game solver per state; same values, for cross-checks)',
           choices=('kernel', 'reference'), default='kernel'),
)

EXPERIMENTS = (
    Experiment(
        'sgcm-table1', f'{PAPER}, Table I and Fig. 4',
        'greedy vs SGCM on the ten cases (Table I, Fig. 4)', 'sgcm.experiments.table1',
        config_file='sgcm/task.yaml', config_option='task', seeded=True, starts_nodes=('mode', ('sim',)),
        options=(Option('--mode', 'core = the abstract game; sim = both arms in pybullet through the nodes, '
                                  'every run recorded and the table computed from the bags',
                        choices=('core', 'sim'), default='core'),
                 *(o if o.flag != '--planner' else replace(o, only_when=('mode', ('core',))) for o in CASE_OPTIONS),
                 Option('--failures', 'core mode: let executions fail with p_fail (default: plan with p_fail, '
                                      'execute without failures, as Table I compares deterministic runs)',
                        action='store_true', default=False, only_when=('mode', ('core',))))),
    Experiment(
        'sgcm-disturbance', f'{PAPER}, Fig. 5',
        'SGCM with disturbed, zero-trust and hostile followers (Fig. 5)', 'sgcm.experiments.disturbance',
        options=CASE_OPTIONS, config_file='sgcm/task.yaml', config_option='task', seeded=True),
)
