"""One stage-wise-utility panel per case (Fig. 4 and Fig. 5 of the SGCM paper)."""
from __future__ import annotations

from collab_tools.experiments import plots


def case_grid(count: int, columns: int = 5):
    """(fig, axes): ``count`` panels with round / stage-wise utility axes; spare panels hidden (no
    more columns than panels, so two cases do not sit in a strip of five)."""
    columns = max(1, min(columns, count))
    rows = (count + columns - 1) // columns
    fig, axes = plots.figure(3.2 * columns, 2.6 * rows, rows=rows, columns=columns, squeeze=False)
    for index, ax in enumerate(axes.flat):
        if index >= count:
            ax.axis('off')
            continue
        ax.set_xlabel('round')
        ax.set_ylabel('stage-wise utility')
        ax.grid(alpha=0.3)
    return fig, axes
