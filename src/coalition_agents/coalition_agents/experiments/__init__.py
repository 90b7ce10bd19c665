"""The IQ-ASyMTRe paper's experiments (``scripts/experiment coalition-*``), one module per table or figure.

Paper: Y. Zhang and L. E. Parker, "IQ-ASyMTRe: Forming Executable Coalitions for Tightly Coupled
Multirobot Tasks", IEEE Transactions on Robotics, doi:10.1109/TRO.2012.2228135 (``iq_asymtre_coalitions``,
CITATION.cff), Section V-A.

==========================================  ======================  ==================================
Paper                                       Experiment              Module
==========================================  ======================  ==================================
Sec. V-A-1, Table III                       coalition-table3        table3 (solution_space_plot)
Sec. V-A-2, Fig. 7 / Table V, core          coalition-fig7          fig7 (fig7_plots; sensing:
                                                                    core.geometric_sensing)
Sec. V-A-2, Fig. 7 / Table V, simulation    coalition-fig7 --mode   fig7_sim
                                            sim
Sec. V-A-4, Fig. 9                          coalition-fig9          fig9 (column)
Sec. V-A-5, Fig. 10/11 box pushing          coalition-boxpush       boxpush (boxpush_inputs)
==========================================  ======================  ==================================

Shared by them: :mod:`.configuration` (config/coalitions/ and the Fig. 7 scenario format, with obstacles),
:mod:`.sessions` (schema_agent nodes on the bridge through the orchestration library),
:mod:`.coalition_bag` (statuses and channel traffic read back from a run's bag).
``scripts/bench coalition`` runs :mod:`.benchmark` (solution-space generation vs referents and robots). Every module
has ``run(request: ExperimentRequest) -> ExperimentResult`` (collab_tools.experiments.api);
this ``__init__`` imports nothing heavy, so listing the experiments stays fast.
"""
from __future__ import annotations

from collab_tools.experiments.api import Experiment, Option

PAPER = 'IQ-ASyMTRe (iq_asymtre_coalitions)'

EXPERIMENTS = (
    Experiment('coalition-table3', f'{PAPER}, Sec. V-A-1, Table III',
               'potential solutions for F_G(local) vs the paper (Table III)',
               'coalition_agents.experiments.table3', config_file='coalitions/costs.yaml'),
    Experiment('coalition-fig7', f'{PAPER}, Sec. V-A-2, Fig. 7 and Table V',
               'possible vs executable coalitions, three clusters (Fig. 7, Table V)',
               'coalition_agents.experiments.fig7',
               (Option('--mode', 'core = geometric sensing, the team search in one process; sim = schema_agent '
                                 'nodes on the bridge, recorded', choices=('core', 'sim'), default='core'),
                Option('--loss', '--mode sim: message loss probability on the agent channel', type=float,
                       default=0.0, only_when=('mode', ('sim',))),
                Option('--scenario', 'scenario file: robots with poses, initiators, task, obstacles (boxes, map) '
                                     '(default config/coalitions/scenarios/fig7.yaml)'),
                Option('--team', 'team capability file (robot types with their sensors\' fov_deg/range_m); '
                                 'default: the scenario\'s team')),
               config_file='coalitions/scenarios/fig7.yaml', config_option='scenario', seeded=('mode', ('sim',)),
               starts_nodes=('mode', ('sim',))),
    Experiment('coalition-fig9', f'{PAPER}, Sec. V-A-4, Fig. 9',
               'column of robots: time to find the coalition, messages (Fig. 9)',
               'coalition_agents.experiments.fig9',
               (Option('--robots', 'column sizes to run (default: the column file\'s)',
                       type=int, nargs='+', metavar='N'),
                Option('--column', 'column file: sizes, spacing, fiducial, link, times '
                                   '(default config/coalitions/scenarios/fig9_column.yaml)')),
               config_file='coalitions/scenarios/fig9_column.yaml', config_option='column', starts_nodes=True),
    Experiment('coalition-boxpush', f'{PAPER}, Sec. V-A-5, Fig. 10/11',
               'box pushing + navigation with executable coalitions, message loss 0 and 0.2 (sim)',
               'coalition_agents.experiments.boxpush',
               (Option('--experiment', 'orchestration file: the bridge and one schema_agent node per robot with its '
                                       'task and goal (default config/experiments/coalition_boxpush.yaml)'),
                Option('--scenario', 'bridge scenario: the robots, the box named box, obstacles (default: the '
                                     'experiment\'s)'),
                Option('--team', 'team capability file (default: the experiment\'s capability_file)'),
                Option('--agents', 'the agents\' shared ROS 2 parameter file (default '
                                   'config/coalitions/boxpush_agents.yaml)')),
               config_file='experiments/coalition_boxpush.yaml', config_option='experiment', seeded=True,
               starts_nodes=True),
)


def experiment_named(name: str) -> Experiment:
    """The entry of ``name`` (KeyError naming the known ones)."""
    for experiment in EXPERIMENTS:
        if experiment.name == name:
            return experiment
    raise KeyError(f"unknown experiment {name!r} (known: {', '.join(e.name for e in EXPERIMENTS)})")


__all__ = ['EXPERIMENTS', 'experiment_named']
