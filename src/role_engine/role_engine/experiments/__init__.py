"""The role engine's experiments (paper role_engine_gp_inference), one module per table or figure.

Listed for ``scripts/experiment`` without importing them (each runs ``<module>.run(request)``):

============== ======================================================== ==========================
name           paper                                                    module
============== ======================================================== ==========================
roles-table3   Table III: E-Map vs straight-line initialisation (GPMP)  :mod:`.table3`
roles-table4   Table IV: GRA vs nearest-neighbour association           :mod:`.table4`
roles-collab   Sec. V-A-3/4, Fig. 11: task- vs role-based collaboration  :mod:`.collab`
roles-formation Sec. V-B, Figs. 15-16: the diamond formation in simulation :mod:`.formation`
============== ======================================================== ==========================

Shared pieces: :mod:`.config` (config/roles/experiments.yaml), :mod:`.problems` (the seeded
problems), :mod:`.gp_sweep` (the environments x problems x sigma_obs sweep and its measures),
:mod:`.table_report` (breakdown tables and figures of Tables III/IV), :mod:`.collab_config`,
:mod:`.collab_simulation` (the core-level simulation driving the nodes' RolePlayer),
:mod:`.path_measures` (distances, contacts, jerk), :mod:`.formation_bag` (the recorded run).
``scripts/bench gpmp`` runs :mod:`.benchmark` (with :mod:`.benchmark_core`).
"""
from collab_tools.experiments.api import Experiment, Option

PAPER = 'Role engine (role_engine_gp_inference)'


def _only(what: str) -> Option:
    return Option('--only', f'run only these {what}', nargs='+', metavar=what.rstrip('s').upper())


EXPERIMENTS = (
    Experiment('roles-table3', f'{PAPER}, Table III', 'E-Map vs straight-line initialisation of GP inference',
               'role_engine.experiments.table3', options=(_only('environments'),)),
    Experiment('roles-table4', f'{PAPER}, Table IV', 'GRA vs nearest-neighbour association, small and large robots',
               'role_engine.experiments.table4', options=(_only('environments'),)),
    Experiment('roles-collab', f'{PAPER}, Sec. V-A-3 and V-A-4 (Fig. 11)',
               'task-based vs role-based collaboration and the narrow-hallway swap (core-level simulation)',
               'role_engine.experiments.collab', options=(_only('scenarios'),)),
    Experiment('roles-formation', f'{PAPER}, Sec. V-B (Figs. 15-16)',
               'four robots of two types form a diamond in simulation through the nodes, recorded',
               'role_engine.experiments.formation',
               options=(Option('--stop-player', "stop this robot's role player mid-run (the others must complete)",
                               metavar='ROBOT'),)),
)
