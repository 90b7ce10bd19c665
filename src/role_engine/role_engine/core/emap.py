"""Environment map (E-Map): the weighted skeleton graph of one robot type's free space (Appendix A).

Construction (Fig. 16):

1. the visitable cells of the robot type (obstacles inflated by its radius, :mod:`.environment`);
2. the skeleton of that free space by thinning (scikit-image's ``skeletonize``, Zhang-Suen),
   then stair artifacts removed: a skeleton pixel whose two orthogonal neighbours already
   touch diagonally, with nothing on the opposite side, is redundant and dropped;
3. feature nodes: junctions (more than two skeleton neighbours), ends (one neighbour) and
   corners where a branch changes direction. Corners are the vertices of a Douglas-Peucker
   simplification of each branch (tolerance ``corner_tolerance`` cells) that also keeps every
   straight segment between consecutive nodes inside the visitable cells, so the polyline
   through the nodes of any graph path is collision-free for the robot's centre;
4. a weighted graph (networkx): an edge per run of skeleton between consecutive feature
   nodes, weighted by the length in metres of that pixel chain (1 or sqrt(2) cells a step).
   Chain lengths are 8-connected path lengths, so the octile distance is an admissible and
   consistent A* heuristic (:mod:`.astar`).

Where the paper is silent: clusters of adjacent junction pixels form one node; a closed
skeleton loop without junctions gets a node of its own; every visitable region gets at
least one skeleton pixel (the one farthest from obstacles) so a small pocket is not lost.
"""
from __future__ import annotations

from dataclasses import dataclass

import networkx as nx
import numpy as np
from scipy import ndimage
from skimage.morphology import skeletonize

from .environment import EIGHT_CONNECTED, RobotEnvironment
from .errors import RoleEngineError
from .grid import DIAGONAL_STEP, line_of_sight

#: The 8 neighbour offsets (dy, dx).
NEIGHBOUR_OFFSETS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
#: Orthogonal neighbour pairs (a, b) defining the four stair corner patterns.
STAIR_PAIRS = [((1, 0), (0, 1)), ((0, 1), (-1, 0)), ((-1, 0), (0, -1)), ((0, -1), (1, 0))]


def neighbour_count(mask: np.ndarray) -> np.ndarray:
    """Number of 8-neighbours set, for every cell (0 where ``mask`` is unset)."""
    kernel = np.ones((3, 3), dtype=int)
    kernel[1, 1] = 0
    counts = ndimage.convolve(mask.astype(int), kernel, mode='constant', cval=0)
    return np.where(mask, counts, 0)


def _is_stair(skeleton: np.ndarray, y: int, x: int) -> bool:
    ny, nx_ = skeleton.shape

    def on(dy: int, dx: int) -> bool:
        yy, xx = y + dy, x + dx
        return 0 <= yy < ny and 0 <= xx < nx_ and bool(skeleton[yy, xx])

    for (ay, ax), (by, bx) in STAIR_PAIRS:
        if (on(ay, ax) and on(by, bx) and not on(-ay, -ax) and not on(-by, -bx)
                and not on(-ay - by, -ax - bx)):
            return True
    return False


def remove_stairs(skeleton: np.ndarray) -> np.ndarray:
    """Drop redundant corner pixels of staircases; 8-connectivity and ends are preserved.

    A pixel is dropped when two orthogonal neighbours (say north and east) are set and
    the three pixels on the opposite side (south, west, south-west) are not: north and
    east touch diagonally, and any remaining neighbour touches one of them. Pixels are
    removed one at a time, so two candidates never disconnect each other.
    """
    result = np.array(skeleton, dtype=bool)
    changed = True
    while changed:
        changed = False
        for y, x in np.argwhere(neighbour_count(result) >= 2):
            if result[y, x] and _is_stair(result, int(y), int(x)):
                result[y, x] = False
                changed = True
    return result


def skeleton_of(visitable: np.ndarray) -> np.ndarray:
    """Thinned, de-staired skeleton of the visitable cells, with a pixel in every region."""
    visitable = np.asarray(visitable, dtype=bool)
    skeleton = remove_stairs(skeletonize(visitable.copy())) & visitable
    labels, count = ndimage.label(visitable, structure=EIGHT_CONNECTED)
    if count:
        covered = np.unique(labels[skeleton])
        missing = np.setdiff1d(np.arange(1, count + 1), covered)
        if missing.size:
            clearance = ndimage.distance_transform_edt(visitable)
            for label in missing:
                region = labels == label
                y, x = np.unravel_index(np.argmax(np.where(region, clearance, -1.0)), region.shape)
                skeleton[y, x] = True
    return skeleton


@dataclass
class EMap:
    """The E-Map of one robot type: skeleton, feature-node graph and the view it was built on.

    ``graph`` nodes are ints with attributes ``cell`` ((iy, ix)), ``position`` (world x, y)
    and ``kind`` ('junction', 'end', 'corner', 'loop' or 'isolated'); edges carry ``weight``
    (m, skeleton chain length) and ``cells`` ((K, 2) pixel chain from the smaller node id).
    """

    robot_env: RobotEnvironment
    skeleton: np.ndarray
    graph: nx.Graph
    corner_tolerance: float

    @property
    def node_cells(self) -> np.ndarray:
        """(M, 2) (iy, ix) of the nodes, in ``node_ids`` order."""
        return np.array([self.graph.nodes[n]['cell'] for n in self.graph.nodes], dtype=int).reshape(-1, 2)

    @property
    def node_ids(self) -> list[int]:
        return list(self.graph.nodes)

    def position(self, node: int) -> tuple[float, float]:
        return self.graph.nodes[node]['position']


def build_emap(robot_env: RobotEnvironment, *, corner_tolerance: float = 1.5) -> EMap:
    """Build the E-Map of one robot type (``Make_Env_map``, Algorithm 2 line 5)."""
    if not (np.isfinite(corner_tolerance) and corner_tolerance > 0):
        raise RoleEngineError(f'emap.corner_tolerance: must be a finite number > 0 cells (got {corner_tolerance})')
    skeleton = skeleton_of(robot_env.visitable)
    builder = _GraphBuilder(skeleton, robot_env, corner_tolerance)
    return EMap(robot_env, skeleton, builder.build(), corner_tolerance)


class _GraphBuilder:
    """Traces skeleton branches between feature pixels and simplifies them into graph edges."""

    def __init__(self, skeleton: np.ndarray, robot_env: RobotEnvironment, tolerance: float):
        self.skeleton = skeleton
        self.free = robot_env.visitable
        self.frame = robot_env.frame
        self.tolerance = tolerance
        self.graph = nx.Graph()
        counts = neighbour_count(skeleton)
        self.kind_of_count = {0: 'isolated', 1: 'end'}
        self.feature = skeleton & (counts != 2)
        self.counts = counts
        # Adjacent junction / end pixels form one node.
        self.cluster, _ = ndimage.label(self.feature, structure=EIGHT_CONNECTED)
        self.node_of_cluster: dict[int, int] = {}
        self.cluster_of_node: dict[int, int] = {}
        self.cluster_parents: dict[int, dict[tuple[int, int], tuple[int, int] | None]] = {}
        self.cluster_pixels: dict[int, list[tuple[int, int]]] = {}
        for y, x in np.argwhere(self.feature):
            self.cluster_pixels.setdefault(int(self.cluster[y, x]), []).append((int(y), int(x)))
        self.visited = np.zeros_like(skeleton, dtype=bool)

    def _add_node(self, cell: tuple[int, int], kind: str) -> int:
        node = self.graph.number_of_nodes()
        position = tuple(float(v) for v in self.frame.cell_to_world(np.array(cell))[0])
        self.graph.add_node(node, cell=(int(cell[0]), int(cell[1])), position=position, kind=kind)
        return node

    def _cluster_node(self, label: int) -> int:
        if label not in self.node_of_cluster:
            pixels = np.array(self.cluster_pixels[label])
            centre = pixels.mean(axis=0)
            representative = pixels[np.argmin(np.sum((pixels - centre) ** 2, axis=1))]
            count = int(self.counts[tuple(representative)])
            kind = 'junction' if len(pixels) > 1 or count >= 3 else self.kind_of_count[count]
            self.node_of_cluster[label] = self._add_node(tuple(representative), kind)
            self.cluster_of_node[self.node_of_cluster[label]] = label
            self.cluster_parents[label] = self._spanning_tree(label, (int(representative[0]), int(representative[1])))
        return self.node_of_cluster[label]

    def _spanning_tree(self, label: int, root: tuple[int, int]) -> dict[tuple[int, int], tuple[int, int] | None]:
        """Breadth-first parents of the cluster's pixels, from its representative."""
        parents: dict[tuple[int, int], tuple[int, int] | None] = {root: None}
        frontier = [root]
        while frontier:
            following = []
            for pixel in frontier:
                for nxt in self._neighbours(*pixel):
                    if nxt not in parents and self.cluster[nxt] == label:
                        parents[nxt] = pixel
                        following.append(nxt)
            frontier = following
        return parents

    def _from_representative(self, node: int, pixel: tuple[int, int]) -> list[tuple[int, int]]:
        """8-connected pixels from a cluster node's representative to one of its pixels."""
        label = self.cluster_of_node.get(node)
        if label is None or pixel not in self.cluster_parents[label]:
            return [self.graph.nodes[node]['cell'], pixel]
        path = [pixel]
        parents = self.cluster_parents[label]
        while parents[path[-1]] is not None:
            path.append(parents[path[-1]])
        return path[::-1]

    def _neighbours(self, y: int, x: int) -> list[tuple[int, int]]:
        ny, nx_ = self.skeleton.shape
        return [(y + dy, x + dx) for dy, dx in NEIGHBOUR_OFFSETS
                if 0 <= y + dy < ny and 0 <= x + dx < nx_ and self.skeleton[y + dy, x + dx]]

    def build(self) -> nx.Graph:
        for label in sorted(self.cluster_pixels):
            start = self._cluster_node(label)
            for pixel in self.cluster_pixels[label]:
                for nxt in self._neighbours(*pixel):
                    if self.feature[nxt] or self.visited[nxt]:
                        continue
                    chain, end_label = self._trace(pixel, nxt)
                    end = self._cluster_node(end_label) if end_label is not None else None
                    self._add_branch(start, end, chain)
        # Closed loops of plain skeleton pixels (no junction or end on them).
        for y, x in np.argwhere(self.skeleton & ~self.feature & ~self.visited):
            if self.visited[y, x]:
                continue
            anchor = (int(y), int(x))
            self.visited[anchor] = True
            node = self._add_node(anchor, 'loop')
            nxt = self._neighbours(*anchor)[0]
            chain, _ = self._trace(anchor, nxt, stop_at=anchor)
            self._add_branch(node, node, chain)
        return self.graph

    def _trace(self, start: tuple[int, int], first: tuple[int, int],
               stop_at: tuple[int, int] | None = None) -> tuple[list[tuple[int, int]], int | None]:
        """Follow plain (two-neighbour) pixels from ``start`` via ``first`` to the next feature."""
        chain = [start, first]
        previous, current = start, first
        while True:
            self.visited[current] = True
            options = [n for n in self._neighbours(*current) if n != previous and n not in chain[-3:-1]]
            ends = [n for n in options if self.feature[n] or n == stop_at]
            if ends:
                chain.append(ends[0])
                return chain, (int(self.cluster[ends[0]]) if self.feature[ends[0]] else None)
            fresh = [n for n in options if not self.visited[n]]
            if not fresh:
                # Dead end inside a plain run cannot happen on a thin skeleton; close the chain here.
                return chain, None
            previous, current = current, fresh[0]
            chain.append(current)

    def _add_branch(self, start_node: int, end_node: int | None, chain: list[tuple[int, int]]) -> None:
        if end_node is None:
            end_node = self._add_node(chain[-1], 'end')
        # Begin and finish at the nodes' representative cells, through the junction clusters'
        # own pixels, so consecutive cells are always 8-neighbours.
        cells = (self._from_representative(start_node, chain[0])[:-1] + list(chain)
                 + self._from_representative(end_node, chain[-1])[::-1][1:])
        cells = [c for k, c in enumerate(cells) if k == 0 or c != cells[k - 1]]
        points = np.array(cells, dtype=int)
        steps = np.abs(np.diff(points, axis=0))
        # Chain step lengths: 1 orthogonal, sqrt(2) diagonal.
        step_lengths = steps.max(axis=1) + (DIAGONAL_STEP - 1.0) * steps.min(axis=1)
        cumulative = np.concatenate([[0.0], np.cumsum(step_lengths)])
        keep = self._simplify(points)
        nodes = [start_node]
        for index in keep[1:-1]:
            nodes.append(self._add_node(tuple(points[index]), 'corner'))
        nodes.append(end_node)
        for (a, b), (i, j) in zip(zip(nodes[:-1], nodes[1:]), zip(keep[:-1], keep[1:])):
            if a == b:
                continue
            weight = float(cumulative[j] - cumulative[i]) * self.frame.resolution
            segment = points[i:j + 1] if a < b else points[i:j + 1][::-1]
            if not self.graph.has_edge(a, b) or self.graph.edges[a, b]['weight'] > weight:
                self.graph.add_edge(a, b, weight=weight, cells=segment)

    def _simplify(self, points: np.ndarray) -> list[int]:
        """Indices kept by Douglas-Peucker with the extra rule that kept segments stay free."""
        keep = {0, len(points) - 1}
        stack = [(0, len(points) - 1)]
        while stack:
            i, j = stack.pop()
            if j - i < 2:
                continue
            a, b = points[i].astype(float), points[j].astype(float)
            inner = points[i + 1:j].astype(float)
            direction = b - a
            length = np.hypot(*direction)
            if length == 0.0:  # closed loop: split at the farthest pixel
                deviation = np.hypot(*(inner - a).T)
            else:
                deviation = np.abs(direction[0] * (inner[:, 1] - a[1]) - direction[1] * (inner[:, 0] - a[0])) / length
            worst = int(np.argmax(deviation))
            if deviation[worst] > self.tolerance or length == 0.0 or not line_of_sight(self.free, a, b):
                split = i + 1 + worst
                keep.add(split)
                stack += [(i, split), (split, j)]
        return sorted(keep)
