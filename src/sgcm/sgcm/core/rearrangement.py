"""The multi-object rearrangement game of Section III and V: states, actions, costs, rewards.

A state s is the number of objects of each colour in each cell, stored flat as an
int vector of length cells * colours (index cell * colours + colour). An action
moves one object of one colour from a cell to a neighbouring cell; index 0 of every
robot's action table is the empty action. The leader moves in 8 directions, the
follower in 4 (configurable); a robot's actions are the moves between cells its arm reaches
(task.workspace.reach: every cell when the arms were placed from the grid).

Rules the paper leaves open, made explicit here:
- An action is feasible in s when its source cell holds an object of its colour and
  its destination cell is below grid.cell_capacity.
- The leader moves first and the follower acts on the state her move left, so he may
  carry on an object she just put down ("relay"). A follower move that finds no object
  or a full destination cell has no effect and costs nothing. Costs (with the clutter
  rule) are computed on the state each robot acts on.
- Each move fails independently with the robot's p_fail; a failed move is the empty
  action (and is charged when cost.charge_failed_actions is true). This gives the four
  outcomes (a^A, a^B), (a^A, 0), (0, a^B), (0, 0) of Section III.

States are identified by a 64-bit key that is linear in the state vector
(key(s) = sum_i s_i h_i mod 2^64 with fixed random h), so the key of a successor is
key(s) + k(a^A) + k(a^B) and whole stages are hashed with vector arithmetic. Distinct
states of one search are checked for key collisions when they are materialised.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .task_config import Case, RobotModel, TaskConfig

LEADER, FOLLOWER = 0, 1
EMPTY = 0  # index of the empty action in every action table

_DIRECTIONS_4 = ((-1, 0), (1, 0), (0, -1), (0, 1))
_DIRECTIONS_8 = _DIRECTIONS_4 + ((-1, -1), (-1, 1), (1, -1), (1, 1))
_DIRECTION_NAMES = {(-1, 0): 'up', (1, 0): 'down', (0, -1): 'left', (0, 1): 'right',
                    (-1, -1): 'up-left', (-1, 1): 'up-right', (1, -1): 'down-left', (1, 1): 'down-right'}


@dataclass(frozen=True)
class Move:
    """A decoded action; ``colour`` is -1 for the empty action."""

    source: int
    target: int
    colour: int

    @property
    def is_empty(self) -> bool:
        return self.colour < 0


EMPTY_MOVE = Move(-1, -1, -1)


class ActionTable:
    """Every action one robot's arm can make on the grid (feasible in a state or not), index 0 empty.

    ``reachable`` (per cell) is the arm's reach (task.workspace.reach, see workspace_layout): a move
    from or to a cell the arm cannot reach is not one of its actions. None: every cell.
    """

    def __init__(self, task: TaskConfig, robot: RobotModel, reachable: tuple[bool, ...] | None = None):
        directions = _DIRECTIONS_8 if robot.directions == 8 else _DIRECTIONS_4
        k = len(task.colours)
        reach = reachable if reachable else (True,) * task.cells
        self.out_of_reach = tuple(cell for cell in range(task.cells) if not reach[cell])
        src, dst, col, diag = [-1], [-1], [-1], [False]
        for cell in range(task.cells):
            row, c = divmod(cell, task.cols)
            for dr, dc in directions:
                r2, c2 = row + dr, c + dc
                if 0 <= r2 < task.rows and 0 <= c2 < task.cols and reach[cell] and reach[r2 * task.cols + c2]:
                    for colour in range(k):
                        src.append(cell)
                        dst.append(r2 * task.cols + c2)
                        col.append(colour)
                        diag.append(dr != 0 and dc != 0)
        self.source = np.array(src)
        self.target = np.array(dst)
        self.colour = np.array(col)
        self.diagonal = np.array(diag)
        self.size = len(src)
        # Index into the flat state of the object taken and of the object placed.
        self.take = np.where(self.colour >= 0, self.source * k + self.colour, 0)
        self.put = np.where(self.colour >= 0, self.target * k + self.colour, 0)
        self.base_cost = np.where(self.diagonal, robot.diagonal_cost, robot.move_cost)
        self.base_cost[EMPTY] = 0.0
        self._index = {(int(s), int(t), int(c)): i for i, (s, t, c)
                       in enumerate(zip(self.source, self.target, self.colour))}

    def move(self, index: int) -> Move:
        return Move(int(self.source[index]), int(self.target[index]), int(self.colour[index]))

    def index_of(self, move: Move) -> int:
        """Action index of a move; raises ValueError if this robot cannot make it."""
        if move.is_empty:
            return EMPTY
        try:
            return self._index[(move.source, move.target, move.colour)]
        except KeyError:
            if move.source in self.out_of_reach or move.target in self.out_of_reach:
                raise ValueError(f"move {move} is not an action of this robot (a cell out of its arm's reach)") \
                    from None
            raise ValueError(f'move {move} is not an action of this robot '
                             '(not a neighbouring cell in its directions)') from None


@dataclass(frozen=True)
class StageMatrices:
    """Everything about the action pairs of one state that the game needs.

    The follower's candidate actions are his moves feasible in s plus the "relay" moves
    of objects the leader may have just put down; a candidate that finds no object (or
    a full destination cell) when his turn comes has no effect and costs nothing.
    """

    leader_actions: np.ndarray      # (m,) indices into the leader's table, EMPTY first
    follower_actions: np.ndarray    # (n,) indices into the follower's table, EMPTY first
    leader_cost: np.ndarray         # (m,)
    follower_cost: np.ndarray       # (m, n) after the leader's move succeeded
    follower_cost_alone: np.ndarray  # (n,) after the leader's move failed
    blocked: np.ndarray             # (m, n) follower move has no effect after the leader's success
    blocked_alone: np.ndarray       # (n,) follower move has no effect after the leader's failure
    outcome_keys: np.ndarray        # (m, n, 4) uint64 keys of (both, leader only, follower only, none)
    outcome_probability: np.ndarray  # (4,)


class RearrangementModel:
    """The game of one task configuration."""

    def __init__(self, task: TaskConfig, hash_seed: int = 0x5C6C):
        self.task = task
        self.colours = len(task.colours)
        self.dim = task.cells * self.colours
        reach = task.workspace.reach or (None, None)
        self.actions = (ActionTable(task, task.leader, reach[LEADER]),
                        ActionTable(task, task.follower, reach[FOLLOWER]))
        rng = np.random.default_rng(hash_seed)
        self.hash_weights = rng.integers(1, 2**63, size=self.dim, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
        # Linear reward weights: value of one object of colour c in cell i.
        distance = self._distance_matrix()
        dmax = distance.max()
        self.object_value = np.zeros(self.dim)
        self.in_goal = np.zeros(self.dim, dtype=bool)
        for colour, goal in enumerate(task.goals):
            for cell in range(task.cells):
                i = cell * self.colours + colour
                self.object_value[i] = task.reward.scale * (dmax - distance[cell, goal])
                self.in_goal[i] = cell == goal
        for table in self.actions:
            # Per action: change of the linear reward and of the misplaced-object count.
            table.reward_delta = np.where(table.colour >= 0,
                                          self.object_value[table.put] - self.object_value[table.take], 0.0)
            table.misplaced_delta = np.where(table.colour >= 0,
                                             self.in_goal[table.take].astype(int)
                                             - self.in_goal[table.put].astype(int), 0)
            table.key_delta = np.where(table.colour >= 0,
                                       self.hash_weights[table.put] - self.hash_weights[table.take],
                                       np.uint64(0)).astype(np.uint64)
        pa = 1.0 - task.leader.failure_probability
        pb = 1.0 - task.follower.failure_probability
        self.outcome_probability = np.array([pa * pb, pa * (1 - pb), (1 - pa) * pb, (1 - pa) * (1 - pb)])
        self._move_vectors = None

    def _distance_matrix(self) -> np.ndarray:
        t = self.task
        rows, cols = np.divmod(np.arange(t.cells), t.cols)
        dr = np.abs(rows[:, None] - rows[None, :])
        dc = np.abs(cols[:, None] - cols[None, :])
        return np.maximum(dr, dc) if t.reward.distance == 'chebyshev' else dr + dc

    # --- states -------------------------------------------------------------------
    def state_of(self, case: Case | np.ndarray) -> np.ndarray:
        counts = case.counts if isinstance(case, Case) else np.asarray(case)
        return np.asarray(counts, dtype=np.int64).reshape(self.dim).copy()

    def goal_state(self, state: np.ndarray) -> np.ndarray:
        """The goal for the objects of ``state``: every object in its colour's goal cell."""
        per_colour = np.asarray(state).reshape(self.task.cells, self.colours).sum(axis=0)
        goal = np.zeros((self.task.cells, self.colours), dtype=np.int64)
        for colour, cell in enumerate(self.task.goals):
            goal[cell, colour] = per_colour[colour]
        return goal.reshape(self.dim)

    def key(self, state: np.ndarray) -> np.uint64:
        return np.uint64(np.sum(np.asarray(state, dtype=np.uint64) * self.hash_weights, dtype=np.uint64))

    def keys(self, states: np.ndarray) -> np.ndarray:
        return (np.asarray(states, dtype=np.uint64) * self.hash_weights).sum(axis=1, dtype=np.uint64)

    def misplaced(self, states: np.ndarray) -> np.ndarray:
        return (np.asarray(states) * ~self.in_goal).sum(axis=-1)

    def reward(self, states: np.ndarray) -> np.ndarray:
        """r(s) for one state (dim,) or a batch (N, dim)."""
        states = np.asarray(states)
        value = states @ self.object_value
        return value + self.task.reward.goal_bonus * (self.misplaced(states) == 0)

    def cell_totals(self, state: np.ndarray) -> np.ndarray:
        return np.asarray(state).reshape(self.task.cells, self.colours).sum(axis=1)

    # --- actions ------------------------------------------------------------------
    def feasible(self, state: np.ndarray, robot: int) -> np.ndarray:
        """Indices of the robot's feasible actions in ``state``, EMPTY first."""
        table = self.actions[robot]
        totals = self.cell_totals(state)
        ok = (np.asarray(state)[table.take] > 0) & (totals[np.maximum(table.target, 0)] < self.task.cell_capacity)
        ok[EMPTY] = True
        return np.flatnonzero(ok)

    def cost(self, state: np.ndarray, robot: int, actions: np.ndarray | int) -> np.ndarray:
        """Cost of the actions in ``state`` with the clutter rule on the source cell."""
        table = self.actions[robot]
        actions = np.asarray(actions)
        totals = self.cell_totals(state)
        crowd = totals[np.maximum(table.source[actions], 0)]
        return table.base_cost[actions] * self.task.clutter.multiplier(crowd)

    def apply(self, state: np.ndarray, robot: int, action: int) -> np.ndarray:
        """State after one robot's successful move (the empty action returns a copy)."""
        table = self.actions[robot]
        new = np.array(state, dtype=np.int64, copy=True)
        if action != EMPTY:
            if new[table.take[action]] <= 0:
                raise ValueError(f'{self.describe(robot, action)}: no such object in the source cell')
            new[table.take[action]] -= 1
            new[table.put[action]] += 1
        return new

    def can_apply(self, state: np.ndarray, robot: int, action: int) -> bool:
        """True if the move finds its object and room in its destination cell."""
        if action == EMPTY:
            return True
        table = self.actions[robot]
        return bool(state[table.take[action]] > 0
                    and self.cell_totals(state)[table.target[action]] < self.task.cell_capacity)

    def step(self, state: np.ndarray, leader_action: int, follower_action: int,
             leader_ok: bool = True, follower_ok: bool = True) -> np.ndarray:
        """Successor state for realised success flags of both moves (leader first)."""
        new = self.apply(state, LEADER, leader_action) if leader_ok else np.array(state, copy=True)
        if follower_ok and self.can_apply(new, FOLLOWER, follower_action):
            new = self.apply(new, FOLLOWER, follower_action)
        return new

    def stage(self, state: np.ndarray, key: np.uint64 | None = None) -> StageMatrices:
        """Candidate actions, costs and the keys of the four outcomes of every action pair."""
        state = np.asarray(state)
        key = self.key(state) if key is None else np.uint64(key)
        la, lb = self.actions
        cap = self.task.cell_capacity
        a = self.feasible(state, LEADER)
        totals = self.cell_totals(state)
        may_hold = state > 0
        may_hold[la.put[a[1:]]] = True
        candidates = may_hold[lb.take]
        candidates[EMPTY] = True
        b = np.flatnonzero(candidates)
        take_b, src_b, dst_b = lb.take[b], np.maximum(lb.source[b], 0), np.maximum(lb.target[b], 0)
        # After the leader's successful move a (rows): objects in the follower's source slot
        # and objects in his source and destination cells.
        same = lambda x, y: (x[:, None] == y[None, :]).astype(np.int64)  # noqa: E731
        held = state[take_b][None, :] - same(la.take[a], take_b) + same(la.put[a], take_b)
        src_total = totals[src_b][None, :] - same(la.source[a], src_b) + same(la.target[a], src_b)
        dst_total = totals[dst_b][None, :] - same(la.source[a], dst_b) + same(la.target[a], dst_b)
        # The empty leader action changes nothing (its table entries are -1 placeholders).
        held[EMPTY], src_total[EMPTY], dst_total[EMPTY] = state[take_b], totals[src_b], totals[dst_b]
        blocked = (held <= 0) | (dst_total >= cap)
        blocked_alone = (state[take_b] <= 0) | (totals[dst_b] >= cap)
        blocked[:, EMPTY] = False
        blocked_alone[EMPTY] = False
        multiplier = self.task.clutter.multiplier
        follower_cost = np.where(blocked, 0.0, lb.base_cost[b][None, :] * multiplier(src_total))
        follower_cost_alone = np.where(blocked_alone, 0.0, lb.base_cost[b] * multiplier(totals[src_b]))
        ka = la.key_delta[a][:, None]
        kb = lb.key_delta[b][None, :]
        keys = np.empty((len(a), len(b), 4), dtype=np.uint64)
        keys[:, :, 0] = key + ka + np.where(blocked, np.uint64(0), kb)
        keys[:, :, 1] = key + ka
        keys[:, :, 2] = key + np.where(blocked_alone, np.uint64(0), kb)
        keys[:, :, 3] = key
        return StageMatrices(a, b, self.cost(state, LEADER, a), follower_cost, follower_cost_alone,
                             blocked, blocked_alone, keys, self.outcome_probability)

    def expected_costs(self, stage: StageMatrices) -> tuple[np.ndarray, np.ndarray]:
        """Expected leader cost (m, 1) and follower cost (m, n) of every pair."""
        p_a = 1.0 - self.task.leader.failure_probability
        p_b = 1.0 - self.task.follower.failure_probability
        ca = stage.leader_cost[:, None]
        cb = p_a * stage.follower_cost + (1.0 - p_a) * stage.follower_cost_alone[None, :]
        if not self.task.charge_failed_actions:
            ca, cb = ca * p_a, cb * p_b
        return ca, cb

    def stage_utilities(self, state_reward: float, stage: StageMatrices) -> tuple[np.ndarray, np.ndarray]:
        """u^A and u^B (m, n) of Section III: r(s) minus the weighted costs."""
        w = self.task.utility
        ca, cb = self.expected_costs(stage)
        ua = state_reward - w.leader_own * ca - w.leader_other * cb
        ub = state_reward - w.follower_own * cb - w.follower_other * ca
        return ua, ub

    def outcome_rewards(self, state: np.ndarray, stage: StageMatrices) -> np.ndarray:
        """r(s') (m, n, 4) of the four outcomes of every pair, from per-action deltas.

        The reward is linear in the state plus the goal bonus on the (also linear)
        misplaced-object count, so no successor state has to be built.
        """
        la, lb = self.actions
        linear = float(state @ self.object_value)
        misplaced = int(self.misplaced(state))
        ra = la.reward_delta[stage.leader_actions][:, None]
        rb = lb.reward_delta[stage.follower_actions][None, :]
        ma = la.misplaced_delta[stage.leader_actions][:, None]
        mb = lb.misplaced_delta[stage.follower_actions][None, :]
        m, n = stage.blocked.shape
        lin = np.empty((m, n, 4))
        mis = np.empty((m, n, 4), dtype=np.int64)
        lin[:, :, 0] = linear + ra + np.where(stage.blocked, 0.0, rb)
        lin[:, :, 1] = linear + ra
        lin[:, :, 2] = linear + np.where(stage.blocked_alone[None, :], 0.0, rb)
        lin[:, :, 3] = linear
        mis[:, :, 0] = misplaced + ma + np.where(stage.blocked, 0, mb)
        mis[:, :, 1] = misplaced + ma
        mis[:, :, 2] = misplaced + np.where(stage.blocked_alone[None, :], 0, mb)
        mis[:, :, 3] = misplaced
        return lin + self.task.reward.goal_bonus * (mis == 0)

    def successor_states(self, state: np.ndarray, stage: StageMatrices) -> np.ndarray:
        """States (m, n, 4, dim) of the outcomes in ``stage`` (for checks and small problems)."""
        ea = self.move_vectors(LEADER)[stage.leader_actions]
        eb = self.move_vectors(FOLLOWER)[stage.follower_actions]
        base = np.asarray(state, dtype=np.int64)
        out = np.empty((len(ea), len(eb), 4, self.dim), dtype=np.int64)
        out[:, :, 0] = base + ea[:, None, :] + np.where(stage.blocked[:, :, None], 0, eb[None, :, :])
        out[:, :, 1] = (base + ea)[:, None, :]
        out[:, :, 2] = (base + np.where(stage.blocked_alone[:, None], 0, eb))[None, :, :]
        out[:, :, 3] = base
        return out

    def move_vectors(self, robot: int) -> np.ndarray:
        """(actions, dim) change of the state made by each of the robot's moves."""
        if self._move_vectors is None:
            self._move_vectors = []
            for table in self.actions:
                vectors = np.zeros((table.size, self.dim), dtype=np.int64)
                nonempty = np.flatnonzero(table.colour >= 0)
                vectors[nonempty, table.take[nonempty]] -= 1
                vectors[nonempty, table.put[nonempty]] += 1
                self._move_vectors.append(vectors)
        return self._move_vectors[robot]

    # --- presentation ---------------------------------------------------------------
    def describe(self, robot: int, action: int) -> str:
        if action == EMPTY:
            return 'no move'
        move = self.actions[robot].move(action)
        return (f'{self.task.colours[move.colour]} {self.task.cell_name(move.source)}'
                f'->{self.task.cell_name(move.target)}')

    def format_state(self, state: np.ndarray) -> str:
        """Compact grid picture: per cell the counts as e.g. 'r2g1'."""
        t = self.task
        grid = np.asarray(state).reshape(t.cells, self.colours)
        lines = []
        for row in range(t.rows):
            cells = []
            for col in range(t.cols):
                counts = grid[row * t.cols + col]
                text = ''.join(f'{t.colours[c][0]}{n}' for c, n in enumerate(counts) if n)
                cells.append(text or '.')
            lines.append(' | '.join(f'{c:>7}' for c in cells))
        return '\n'.join(lines)
