"""The FSE planner on the compiled kernel (the default), and the choice between it and the reference.

:class:`CompiledFSEPlanner` computes what :class:`.fse.FSEPlanner` (the reference: numpy per state
and a stage-game solver per state) computes, with the same interface (``plan(state) -> FSEResult``,
``horizon``, ``solver``): forward prediction and whole stages of the dynamic programme run in
:mod:`.fse_kernel` over integer state arrays (:mod:`.game_tables`).

- Cooperative games (U^A = U^B, :func:`.game_tables.is_cooperative`; the guidance set-up): each
  stage game is settled in the kernel by its maximal entry, ties by the rule documented in
  :mod:`.fse_kernel` (the reference solver's choice); no stage-game solver is called. A state the
  rule cannot settle (it never happens when U^A = U^B) goes to the selected solver.
- General-sum games: the kernel builds each state's U^A, U^B and the selected solver of
  :mod:`.stage_game` (``fast``: multiple LPs, ``milp``: the paper's MILP) solves it, as in the
  reference.

Values equal the reference's to a few ulps (the kernel repeats its arithmetic) and the chosen
actions are the same; ``scripts/bench sgcm`` and test_sgcm_kernel*.py compare both paths.

:func:`make_planner` builds either path (``PLANNER_PATHS``; the nodes' ``planner`` setting, the
experiments' ``--planner`` option). Numba compiles the kernels once and caches them on disk
(``cache=True``: next to the sources in ``__pycache__``, or numba's user cache directory when
that is read-only); a planner warms them up when it is built (:func:`warm_up`), so no compilation
lands in a node's first round.
"""
from __future__ import annotations

import time

import numpy as np

from .fse import FSEPlanner, FSEResult, planner_horizon
from .fse_kernel import build_table, expand_level, level_games, solve_level_pure
from .game_tables import GameTables, is_cooperative
from .rearrangement import RearrangementModel
from .stage_game import DEFAULT_TOLERANCE, SOLVERS, StageSolution

#: kernel: the compiled path (default); reference: fse.FSEPlanner (numpy + a solver per state).
PLANNER_PATHS = ('kernel', 'reference')
#: States per slice handed from the kernel to a stage-game solver (general-sum games).
SLICE = 256

_NO_NEXT = (np.zeros((1, 2), np.uint64), np.zeros(1), np.zeros(1))
_warm = False


def make_planner(model: RearrangementModel, horizon: int | None = None, solver: str = 'fast',
                 path: str = 'kernel', **options) -> FSEPlanner | 'CompiledFSEPlanner':
    """The FSE planner of ``path`` ('kernel' or 'reference')."""
    if path not in PLANNER_PATHS:
        raise ValueError(f"planner: must be one of {', '.join(PLANNER_PATHS)} (got '{path}')")
    cls = CompiledFSEPlanner if path == 'kernel' else FSEPlanner
    return cls(model, horizon=horizon, solver=solver, **options)


def warm_up() -> None:
    """Load (or compile, the first time on this machine) every kernel, on a two-cell toy game."""
    global _warm
    if _warm:
        return
    from .task_config import parse_task
    _warm = True
    for weights in ({}, {'follower': {'own_cost': 2.0, 'other_cost': 0.0}}):
        task = parse_task({'grid': {'rows': 1, 'cols': 2}, 'colours': {'red': {'goal': [0, 1], 'rgb': [1.0, 0.0, 0.0]}},
                           'utility': weights, 'game': {'horizon': 2}})
        model = RearrangementModel(task)
        CompiledFSEPlanner(model, warm=False).plan(np.array([1, 0], dtype=np.int64))


class CompiledFSEPlanner:
    """pi_0^{A*}, pi_0^{B*} from an observed state, on the compiled kernel (see the module docstring).

    Options as :class:`.fse.FSEPlanner`; ``count_terminal_states`` adds |S_T| to states_per_stage
    (timed with the round, as in the reference); ``warm``: load the kernels now.
    """

    path = 'kernel'

    def __init__(self, model: RearrangementModel, horizon: int | None = None, solver: str = 'fast',
                 count_terminal_states: bool = False, tolerance: float = DEFAULT_TOLERANCE, warm: bool = True):
        self.model = model
        self.horizon = planner_horizon(model, horizon, solver)
        self.solver = solver
        self.solve_stage = SOLVERS[solver]
        self.tolerance = tolerance
        self.cooperative = is_cooperative(model.task)
        self.count_terminal_states = count_terminal_states
        self.tables = GameTables.of(model, tolerance)
        self._games: dict[int, tuple] = {}
        if warm:
            warm_up()

    def _game(self, objects: int) -> tuple:
        if objects not in self._games:
            self._games[objects] = self.tables.kernel_arguments(objects)
        return self._games[objects]

    def levels(self, state: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """S_0 .. S_{T-1}: (states, keys, hash table) per stage (Algorithm 1 lines 3-10)."""
        state = np.asarray(state, dtype=np.int64).reshape(1, -1)
        game = self._game(int(state.sum()))
        keys = np.array([self.model.key(state[0])], dtype=np.uint64)
        levels = [(state.copy(), keys, build_table(keys))]
        for _ in range(self.horizon - 1):
            levels.append(expand_level(levels[-1][0], levels[-1][1], game, True))
        return levels

    def terminal_states(self, state: np.ndarray) -> int:
        """|S_T| (hashed, never materialised)."""
        states, keys, _ = self.levels(state)[-1]
        return int(len(expand_level(states, keys, self._game(int(np.sum(state))), False)[1]))

    def plan(self, state: np.ndarray) -> FSEResult:
        start = time.perf_counter()
        state = np.asarray(state, dtype=np.int64)
        game = self._game(int(state.sum()))
        levels = self.levels(state)
        nxt = _NO_NEXT
        programs = 0
        root = None
        for t in range(self.horizon - 1, -1, -1):
            states, keys, table = levels[t]
            terminal = t == self.horizon - 1
            if self.cooperative:
                va, vb, leader, follower, settled = solve_level_pure(states, keys, game, terminal, *nxt)
                unsettled = np.flatnonzero(~settled)
            else:
                va, vb = np.empty(len(states)), np.empty(len(states))
                leader = follower = None
                unsettled = np.arange(len(states))
            for lo in range(0, len(unsettled), SLICE):
                rows = unsettled[lo:lo + SLICE]
                solved = self._solve_states(states[rows], keys[rows], game, terminal, nxt)
                for row, (solution, acts_a, acts_b) in zip(rows, solved):
                    va[row], vb[row] = solution.leader_value, solution.follower_value
                    programs += solution.programs_solved
                    if t == 0:
                        root = (solution, acts_a, acts_b)
            if t == 0 and root is None:   # settled in the kernel: a pure commitment
                root = (StageSolution(np.ones(1), 0, float(va[0]), float(vb[0]), 0),
                        leader[:1], follower[:1])
            nxt = (table, va, vb)
        solution, acts_a, acts_b = root
        support = np.flatnonzero(solution.leader_policy > 1e-12)
        sizes = [len(keys) for _, keys, _ in levels]
        if self.count_terminal_states:
            states, keys, _ = levels[-1]
            sizes.append(int(len(expand_level(states, keys, game, False)[1])))
        return FSEResult(
            leader_policy=solution.leader_policy[support], leader_actions=np.asarray(acts_a)[support],
            leader_action=int(acts_a[solution.leader_action]), follower_action=int(acts_b[solution.follower_action]),
            leader_value=solution.leader_value, follower_value=solution.follower_value,
            states_per_stage=sizes, stage_games=sum(sizes[:self.horizon]), programs_solved=programs,
            seconds=time.perf_counter() - start)

    def _solve_states(self, states, keys, game, terminal, nxt) -> list[tuple[StageSolution, np.ndarray, np.ndarray]]:
        """The selected stage-game solver on each state's U^A, U^B built by the kernel."""
        ms, ns, offsets, flat_a, flat_b, offsets_a, acts_a, offsets_b, acts_b = level_games(
            states, keys, game, terminal, *nxt)
        out = []
        for i in range(len(states)):
            shape = (ms[i], ns[i])
            ua = flat_a[offsets[i]:offsets[i + 1]].reshape(shape)
            ub = flat_b[offsets[i]:offsets[i + 1]].reshape(shape)
            out.append((self.solve_stage(ua, ub), acts_a[offsets_a[i]:offsets_a[i + 1]],
                        acts_b[offsets_b[i]:offsets_b[i + 1]]))
        return out
