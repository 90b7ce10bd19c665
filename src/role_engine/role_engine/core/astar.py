"""Auxiliary nodes: A* on the E-Map with the octile heuristic, then line-of-sight reduction (Appendix A-B).

``Find_Aux`` of Algorithm 2 (line 9). The source and the destination are joined to the
E-Map at the nearest feature nodes they can see in a straight line (up to
``attach_count`` of them, so A* can leave in either direction along a corridor); A*
(networkx, octile-distance heuristic on the node cells) finds the shortest path on the
graph; the nodes along it are then reduced by line of sight on the robot type's
visitable cells: from each kept node the path jumps to the farthest later node it can
see. No path means the pair is infeasible for that robot type (``Q = inf``).

Where the paper is silent: a point that sees no feature node (it sits behind a corner of
its pocket) is joined through the shortest 8-connected grid path to the nearest node,
reduced the same way; an edge straight from source to destination is added when they
see each other.
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from .emap import EMap
from .errors import RoleEngineError
from .grid import DIAGONAL_STEP, line_of_sight, octile_distance

SOURCE = 'source'
DESTINATION = 'destination'


@dataclass
class AuxiliaryPath:
    """Result of one source-destination query.

    ``waypoints`` (K, 2) world x, y: source, reduced auxiliary nodes, destination (empty
    when infeasible). ``graph_waypoints``: the same before line-of-sight reduction.
    ``length``: polyline length of ``waypoints`` in m (inf when infeasible).
    """

    feasible: bool
    waypoints: np.ndarray
    graph_waypoints: np.ndarray
    length: float
    reason: str = ''
    graph_nodes: list[int] = field(default_factory=list)


def _infeasible(reason: str) -> AuxiliaryPath:
    empty = np.zeros((0, 2))
    return AuxiliaryPath(False, empty, empty, math.inf, reason)


def polyline_length(points: np.ndarray) -> float:
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T))) if len(points) > 1 else 0.0


def reduce_by_line_of_sight(cells: np.ndarray, free: np.ndarray) -> list[int]:
    """Indices of the points kept when each kept point jumps to the farthest one it sees."""
    kept = [0]
    last = len(cells) - 1
    while kept[-1] < last:
        i = kept[-1]
        j = last
        while j > i + 1 and not line_of_sight(free, cells[i], cells[j]):
            j -= 1
        kept.append(j)
    return kept


class EMapPlanner:
    """Answers source-destination queries on one E-Map; joins of repeated points are cached."""

    def __init__(self, emap: EMap, *, attach_count: int = 4, attach_candidates: int = 40):
        if attach_count < 1 or attach_candidates < attach_count:
            raise RoleEngineError('planner: need 1 <= attach_count <= attach_candidates '
                                  f'(got {attach_count}, {attach_candidates})')
        self.emap = emap
        self.robot_env = emap.robot_env
        self.frame = emap.robot_env.frame
        self.attach_count = attach_count
        self.attach_candidates = attach_candidates
        self._nodes = emap.node_ids
        self._node_cells = emap.node_cells
        self._node_components = (self.robot_env.components[self._node_cells[:, 0], self._node_cells[:, 1]]
                                 if len(self._nodes) else np.zeros(0, dtype=int))
        # point -> list of (chain of fractional (iy, ix) cells from the point to a node, node, weight m)
        self._joins: dict[tuple[float, float], list[tuple[np.ndarray, int, float]]] = {}

    # ------------------------------------------------------------------ geometry helpers
    def _fractional_cell(self, point: np.ndarray) -> np.ndarray:
        return self.frame.world_to_continuous(point)[0, ::-1]

    def _cells_to_world(self, cells: np.ndarray) -> np.ndarray:
        return self.frame.cell_to_world(cells)

    def _check_point(self, point, role: str) -> tuple[np.ndarray | None, str]:
        point = np.asarray(point, dtype=float)
        if point.shape != (2,) or not np.isfinite(point).all():
            raise RoleEngineError(f'{role}: must be a finite world point (x, y) (got {point.tolist()})')
        if not self.robot_env.is_visitable(point):
            name = self.robot_env.robot_type.name
            return None, (f'{role} ({point[0]:.3f}, {point[1]:.3f}) is not visitable for robot type '
                          f"'{name}' (off the map or within {self.robot_env.robot_type.inflation:.3f} m "
                          'of an obstacle)')
        return point, ''

    # ------------------------------------------------------------------ joining points to the graph
    def _joins_of(self, point: np.ndarray) -> list[tuple[np.ndarray, int, float]]:
        key = (float(point[0]), float(point[1]))
        if key not in self._joins:
            self._joins[key] = self._compute_joins(point)
        return self._joins[key]

    def _compute_joins(self, point: np.ndarray) -> list[tuple[np.ndarray, int, float]]:
        cell = self._fractional_cell(point)
        component = self.robot_env.components[self.robot_env.cell_of(point)]
        same = np.flatnonzero(self._node_components == component)
        if same.size == 0:
            return []
        order = same[np.argsort(np.hypot(*(self._node_cells[same] - cell).T))]
        joins = []
        for index in order[:self.attach_candidates]:
            node_cell = self._node_cells[index]
            if line_of_sight(self.robot_env.visitable, cell, node_cell):
                weight = float(octile_distance(cell, node_cell)) * self.frame.resolution
                joins.append((np.array([cell, node_cell], dtype=float), self._nodes[index], weight))
                if len(joins) == self.attach_count:
                    break
        if not joins:
            joins = self._join_by_grid_search(cell, component)
        return joins

    def _join_by_grid_search(self, cell: np.ndarray, component: int) -> list[tuple[np.ndarray, int, float]]:
        """Shortest 8-connected grid path from the point's cell to the nearest node cell."""
        free = self.robot_env.visitable
        targets = {tuple(c): n for c, n, comp in zip(map(tuple, self._node_cells), self._nodes,
                                                     self._node_components) if comp == component}
        start = tuple(int(v) for v in np.floor(cell + 0.5))
        distance = {start: 0.0}
        parent: dict[tuple[int, int], tuple[int, int]] = {}
        queue = [(0.0, start)]
        ny, nx_ = free.shape
        while queue:
            cost, current = heapq.heappop(queue)
            if cost > distance[current]:
                continue
            if current in targets:
                chain = [current]
                while chain[-1] != start:
                    chain.append(parent[chain[-1]])
                chain = np.array(chain[::-1], dtype=float)
                chain[0] = cell
                kept = reduce_by_line_of_sight(chain, free)
                return [(chain[kept], targets[current], cost * self.frame.resolution)]
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    nxt = (current[0] + dy, current[1] + dx)
                    if (dy or dx) and 0 <= nxt[0] < ny and 0 <= nxt[1] < nx_ and free[nxt]:
                        step = DIAGONAL_STEP if dy and dx else 1.0
                        if cost + step < distance.get(nxt, math.inf):
                            distance[nxt] = cost + step
                            parent[nxt] = current
                            heapq.heappush(queue, (cost + step, nxt))
        return []

    # ------------------------------------------------------------------ the query
    def plan(self, source, destination, *, reduce: bool = True) -> AuxiliaryPath:
        """Auxiliary nodes from ``source`` to ``destination`` (world x, y)."""
        source, reason = self._check_point(source, 'source')
        if source is None:
            return _infeasible(reason)
        destination, reason = self._check_point(destination, 'destination')
        if destination is None:
            return _infeasible(reason)
        env = self.robot_env
        if env.components[env.cell_of(source)] != env.components[env.cell_of(destination)]:
            return _infeasible(f"no path for robot type '{env.robot_type.name}': source "
                               f'({source[0]:.3f}, {source[1]:.3f}) and destination '
                               f'({destination[0]:.3f}, {destination[1]:.3f}) lie in separate free regions')
        graph = self.emap.graph.copy()
        cell_of = {SOURCE: self._fractional_cell(source), DESTINATION: self._fractional_cell(destination)}
        via: dict[tuple, np.ndarray] = {}  # (endpoint, node) -> intermediate cells of a grid-search join
        for end in (SOURCE, DESTINATION):
            graph.add_node(end)
            for chain, node, weight in self._joins_of(source if end == SOURCE else destination):
                graph.add_edge(end, node, weight=weight)
                via[(end, node)] = chain[1:-1]
        if line_of_sight(env.visitable, cell_of[SOURCE], cell_of[DESTINATION]):
            weight = float(octile_distance(cell_of[SOURCE], cell_of[DESTINATION])) * self.frame.resolution
            graph.add_edge(SOURCE, DESTINATION, weight=weight)

        def cell(node) -> np.ndarray:
            return cell_of[node] if node in cell_of else np.asarray(graph.nodes[node]['cell'], dtype=float)

        def heuristic(a, b) -> float:  # octile distance, admissible for chain-length weights
            return float(octile_distance(cell(a), cell(b))) * self.frame.resolution

        try:
            nodes = nx.astar_path(graph, SOURCE, DESTINATION, heuristic=heuristic, weight='weight')
        except nx.NetworkXNoPath:
            return _infeasible(f"no path on the E-Map of robot type '{env.robot_type.name}' from "
                               f'({source[0]:.3f}, {source[1]:.3f}) to ({destination[0]:.3f}, {destination[1]:.3f})')
        cells = [cell(nodes[0])]
        for a, b in zip(nodes[:-1], nodes[1:]):
            if (a, b) in via:
                cells.extend(via[(a, b)])
            elif (b, a) in via:
                cells.extend(via[(b, a)][::-1])
            cells.append(cell(b))
        cells = np.array(cells, dtype=float)
        kept = reduce_by_line_of_sight(cells, env.visitable) if reduce else list(range(len(cells)))
        graph_points = self._to_world(cells, source, destination)
        points = graph_points[kept]
        return AuxiliaryPath(True, points, graph_points, polyline_length(points),
                             graph_nodes=[n for n in nodes if n not in (SOURCE, DESTINATION)])

    def _to_world(self, cells: np.ndarray, source: np.ndarray, destination: np.ndarray) -> np.ndarray:
        points = self._cells_to_world(cells)
        points[0], points[-1] = source, destination  # exact, not snapped to cell centres
        return points
