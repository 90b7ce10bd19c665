"""roles-formation's plots draw what the simulation drew: each robot in its scenario colour, the walls and
obstacles under the paths (the shared report helpers, as scripts/report's trajectory plots)."""
import numpy as np
import pytest
from matplotlib.colors import to_rgb

from collab_tools.core.scene_layout import Disc, Rect, SceneLayout
from collab_tools.experiments import plots
from role_engine.experiments.formation import plot_commanded_vs_tracked, plot_commands
from role_engine.experiments.formation_bag import FormationLog

RED, BLUE, CRATE = (0.85, 0.15, 0.15), (0.15, 0.35, 0.85), (0.55, 0.45, 0.3)
SCENE = SceneLayout(bounds=(-2.0, -2.0, 2.0, 2.0),
                    walls=(Rect('walls', (0.0, 2.025), (4.1, 0.05), 0.0, (0.3, 0.3, 0.3)),),
                    obstacles=(Rect('crate', (0.0, 0.0), (0.4, 0.4), 0.0, CRATE),),
                    robots={'pioneer_1': Disc('pioneer_1', (-1.0, -1.0), 0.2, RED),
                            'burger_1': Disc('burger_1', (1.0, 1.0), 0.1, BLUE)})


@pytest.fixture
def saved(monkeypatch):
    """The figures the plot functions save (kept open for inspection)."""
    figures = []

    def keep(fig, path, *args, **kwargs):
        figures.append(fig)
        fig.savefig(path)
        return path
    monkeypatch.setattr(plots, 'save', keep)
    yield figures
    plots.plt.close('all')


def formation_log():
    times = np.linspace(0.0, 10.0, 21)
    line = np.linspace(-1.0, 1.0, 21)
    commands = np.column_stack([times, np.full(21, 0.2), np.zeros(21)])
    return FormationLog(truth_times=times,
                        truth={'pioneer_1': np.column_stack([line, line]), 'burger_1': np.column_stack([-line, line])},
                        commands={'pioneer_1': commands, 'burger_1': commands})


RESULTS = {'robots': {'pioneer_1': {'goal': [1.0, 1.0]}, 'burger_1': {'goal': [-1.0, 1.0]}}}


def line_colours(ax) -> dict[str, tuple]:
    return {line.get_label(): to_rgb(line.get_color()) for line in ax.lines if not line.get_label().startswith('_')}


def test_each_robot_is_drawn_in_its_simulation_colour_over_the_scene(saved, tmp_path):
    plot_commanded_vs_tracked(formation_log(), RESULTS, tmp_path / 'tracked.png', SCENE)
    ax, ax_err = saved[0].axes
    colours = line_colours(ax)
    assert colours['pioneer_1 actual'] == colours['pioneer_1 commanded'] == pytest.approx(RED)
    assert colours['burger_1 actual'] == pytest.approx(BLUE)
    assert line_colours(ax_err) == {'pioneer_1': pytest.approx(RED), 'burger_1': pytest.approx(BLUE)}
    faces = [tuple(p.get_facecolor()[:3]) for p in ax.patches]
    assert pytest.approx(CRATE) in faces and pytest.approx((0.3, 0.3, 0.3)) in faces   # crate and wall drawn
    assert ax.get_xlim()[0] < -2.0 and ax.get_xlim()[1] > 2.0                         # the arena in view
    assert (tmp_path / 'tracked.png').stat().st_size > 10_000


def test_commands_use_the_same_colours(saved, tmp_path):
    plot_commands(formation_log(), tmp_path / 'cmd.png', SCENE)
    ax_v, ax_w = saved[0].axes
    assert line_colours(ax_v) == line_colours(ax_w) == {'pioneer_1': pytest.approx(RED), 'burger_1': pytest.approx(BLUE)}


def test_without_a_scene_the_robots_still_get_distinct_colours(saved, tmp_path):
    plot_commanded_vs_tracked(formation_log(), RESULTS, tmp_path / 'tracked.png')
    colours = line_colours(saved[0].axes[0])
    assert colours['pioneer_1 actual'] != colours['burger_1 actual']
    assert not saved[0].axes[0].patches

