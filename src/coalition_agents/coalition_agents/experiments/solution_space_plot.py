"""Drawing a solution space's and-or tree (``solution_space.png`` of coalition-table3).

The paper draws solution spaces as and-or trees (Section IV-C, Fig. 3/4/10): schemas as nodes,
information flowing from the leaves (sensors, CSs) to the root (the MS), tOR nodes where an
instance has more than one alternative. This draws a :class:`~..core.SolutionSpace` that way,
root at the left, shared sub-trees repeated.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from collab_tools.experiments import plots
from collab_tools.experiments.plots import plt

from ..core import SchemaKind, SolutionSpace
from ..core.solution_space import RequirementNode, SchemaNode


@dataclass
class _DrawNode:
    text: str
    kind: str            # 'schema' | 'tor'
    schema_kind: SchemaKind | None
    children: list['_DrawNode']
    x: float = 0.0
    y: float = 0.0


def _draw_tree(space: SolutionSpace) -> _DrawNode:
    def schema(node: SchemaNode) -> _DrawNode:
        head = f'{node.kind.short} {node.schema}' if node.kind is not SchemaKind.CS else 'CS'
        text = head if node.output is None else f'{head}\n→ {node.output}'
        return _DrawNode(f'{text}   [{node.cost:g}]', 'schema', node.kind, [requirement(r) for r in node.inputs])

    def requirement(node: RequirementNode) -> _DrawNode:
        if len(node.options) == 1:
            return schema(node.options[0])
        return _DrawNode(f'tOR {node.instance}', 'tor', None, [schema(o) for o in node.options])

    assert space.root is not None
    return schema(space.root)


def _layout(root: _DrawNode) -> tuple[int, int]:
    """Leaves on consecutive rows, parents centred on their children; x = depth."""
    next_row = [0]
    depth_max = [0]

    def place(node: _DrawNode, depth: int) -> None:
        node.x = depth
        depth_max[0] = max(depth_max[0], depth)
        if not node.children:
            node.y = next_row[0]
            next_row[0] += 1
            return
        for child in node.children:
            place(child, depth + 1)
        node.y = (node.children[0].y + node.children[-1].y) / 2

    place(root, 0)
    return next_row[0], depth_max[0]


def _walk(node: _DrawNode) -> Iterator[_DrawNode]:
    yield node
    for child in node.children:
        yield from _walk(child)


_KIND_COLOURS = {SchemaKind.MS: '#f4cccc', SchemaKind.RPS: '#cfe2f3', SchemaKind.PS: '#cfe2f3',
                 SchemaKind.ES_EPS: '#d9ead3', SchemaKind.CS: '#fff2cc', SchemaKind.PRIOR: '#eeeeee'}


def plot_solution_space(space: SolutionSpace, path: Path, title: str) -> None:
    """The and-or tree, root at the left, information flowing right to left (leaves at the right)."""
    root = _draw_tree(space)
    leaves, depth = _layout(root)
    fig, ax = plt.subplots(figsize=(1.75 * (depth + 1) + 0.5, 0.5 * leaves + 1.6))
    artists = {}
    for node in _walk(root):
        if node.kind == 'tor':
            box = {'boxstyle': 'round4,pad=0.3', 'fc': 'white', 'ec': '#aa0000', 'ls': '--'}
            artists[id(node)] = ax.text(node.x, -node.y, node.text, ha='center', va='center', fontsize=8,
                                        color='#aa0000', bbox=box)
        else:
            box = {'boxstyle': 'round,pad=0.3', 'fc': _KIND_COLOURS.get(node.schema_kind, 'white'), 'ec': '#333333'}
            artists[id(node)] = ax.text(node.x, -node.y, node.text, ha='center', va='center', fontsize=8, bbox=box)
    for node in _walk(root):
        for child in node.children:
            # From the child's left edge to the parent's right edge: information flows to the root.
            ax.annotate('', xy=(1.0, 0.5), xycoords=artists[id(node)], xytext=(0.0, 0.5),
                        textcoords=artists[id(child)],
                        arrowprops={'arrowstyle': '->', 'color': '#666666', 'lw': 0.8, 'shrinkA': 2, 'shrinkB': 2})
    ax.set_xlim(-0.6, depth + 0.6)
    ax.set_ylim(-leaves + 0.3, 0.7)
    ax.axis('off')
    kinds = [kind for kind in _KIND_COLOURS if any(n.schema_kind is kind for n in _walk(root))]
    handles = [plt.Rectangle((0, 0), 1, 1, fc=_KIND_COLOURS[k], ec='#333333') for k in kinds]
    ax.legend(handles, [k.short for k in kinds], loc='lower left', fontsize=8, ncol=len(kinds), frameon=False)
    ax.set_title(f'{title}\nboxes: schemas with [cost]; dashed: tOR choice; arrows: information flow '
                 f'({space.count_potential_solutions()} potential solutions)', fontsize=9)
    fig.tight_layout()
    plots.save(fig, path, dpi=110)



__all__ = ['plot_solution_space']
