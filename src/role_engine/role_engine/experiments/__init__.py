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

Inputs from the command line (besides scripts/experiment's ``--config``/``--set``): ``roles-table3/4
[--maps YAML ...] [--map-image PNG --resolution M [--origin X Y [YAW]]] [--only NAME ...]``;
``roles-formation [--settings FILE] [--map NAV2_YAML]`` (:mod:`.formation_inputs`). Maps are Nav2 map YAMLs
(core.environment).

Shared pieces: :mod:`.config` (config/roles/experiments.yaml and the table inputs), :mod:`.problems` (the seeded
problems), :mod:`.gp_sweep` (the environments x problems x sigma_obs sweep and its measures),
:mod:`.table_report` (breakdown tables and figures of Tables III/IV), :mod:`.paper_comparison` (Tables III/IV
beside the paper: claims in kind, stopping rules, scale probe, for paper_notes.md), :mod:`.collab_config`,
:mod:`.collab_simulation` (the core-level simulation driving the nodes' RolePlayer),
:mod:`.path_measures` (distances, obstacle clearance, contacts, jerk), :mod:`.formation_bag` (the recorded
run), :mod:`.formation_inputs` (the formation's team, map and generated run files).
``scripts/bench gpmp`` runs :mod:`.benchmark` (with :mod:`.benchmark_core`).
"""
from collab_tools.experiments.api import Experiment, Option

PAPER = 'Role engine (role_engine_gp_inference)'


def _only(what: str) -> Option:
    return Option('--only', f'run only these {what}', nargs='+', metavar=what.rstrip('s').upper())


#: The table experiments' inputs (experiments/config.py table_config): settings file, map list or map image.
TABLE_INPUTS = (
    Option('--maps', 'Nav2 map YAMLs that replace the settings file\'s environments (named by file stem)',
           nargs='+', metavar='YAML'),
    Option('--map-image', 'one occupancy image as the only environment (white free, black occupied)',
           metavar='IMAGE'),
    Option('--resolution', 'm per pixel of --map-image', type=float, metavar='M'),
    Option('--origin', 'x y [yaw] of --map-image\'s bottom-left corner (default 0 0 0)', type=float, nargs='+',
           metavar='V'),
)


EXPERIMENTS = (
    Experiment('roles-table3', f'{PAPER}, Table III', 'E-Map vs straight-line initialisation of GP inference',
               'role_engine.experiments.table3', options=(_only('environments'), *TABLE_INPUTS),
               config_file='roles/experiments.yaml'),
    Experiment('roles-table4', f'{PAPER}, Table IV', 'GRA vs nearest-neighbour association, small and large robots',
               'role_engine.experiments.table4', options=(_only('environments'), *TABLE_INPUTS),
               config_file='roles/experiments.yaml'),
    Experiment('roles-collab', f'{PAPER}, Sec. V-A-3 and V-A-4 (Fig. 11)',
               'task-based vs role-based collaboration and the narrow-hallway swap (core-level simulation)',
               'role_engine.experiments.collab', options=(_only('scenarios'),), config_file='roles/collab.yaml'),
    Experiment('roles-formation', f'{PAPER}, Sec. V-B (Figs. 15-16)',
               'four robots of two types form a diamond in simulation through the nodes, recorded',
               'role_engine.experiments.formation', config_file='roles/formation_demo.yaml',
               config_option='settings', starts_nodes=True,
               options=(Option('--settings', 'the role nodes\' settings file; its scenario is the team (default '
                               'config/roles/formation_demo.yaml)', metavar='FILE'),
                        Option('--map', 'a Nav2 map YAML: the simulated obstacles (replaces the scenario\'s)',
                               metavar='YAML'),
                        Option('--stop-player', "stop this robot's role player mid-run (the others must complete)",
                               metavar='ROBOT'))),
)
