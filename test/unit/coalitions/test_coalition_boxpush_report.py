"""coalition-boxpush without a simulator (the session and the bag reading replaced): summary.md opens with the
outcome line, and the trajectories plot draws each robot in its simulation colour over the scene."""
from pathlib import Path
from types import SimpleNamespace

import pytest
from matplotlib.colors import to_rgb

from collab_tools.core.run_outcome import outcome_markdown, run_outcomes
from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, run_experiment
from coalition_agents.experiments import boxpush, experiment_named

WORKSPACE = Path(__file__).resolve().parents[3]
SCENARIO = WORKSPACE / 'config' / 'scenarios' / 'coalition_boxpush.yaml'


def canned_run(box_end: float) -> dict:
    """read_run's answer: the box pushed along +x, pusher_g1 behind it, pusher_r2 navigating."""
    return {
        'coalitions': {'c1': {'leader': 'pusher_g1', 'members': ['pusher_g1', 'pusher_r1'], 'cost': 3.0,
                              'established_at_s': 1.0}},
        'time_to_form_s': {'pusher_g1': 1.0, 'pusher_r2': 2.0}, 'reforms': {'pusher_g1': 0, 'pusher_r2': 0},
        'robots': {}, 'messages': {'request': 4}, 'ros_messages': 10, 'conflicts': [],
        'box': {'leader': 'pusher_g1', 'goal': [1.5, 1.5], 'final_distance_m': round(1.5 - box_end, 3),
                'completed': True, 'reached': 1.5 - box_end <= 0.3},
        'navigation': {'leader': 'pusher_r2', 'goal': [1.0, -3.0], 'final_distance_m': 0.1, 'completed': True,
                       'reached': True},
        'trajectories': {'box': [[0.0, -1.0, 1.5], [10.0, box_end, 1.5]],
                         'pusher_g1': [[0.0, -1.58, 1.82], [10.0, box_end - 0.6, 1.82]],
                         'pusher_r2': [[0.0, -3.0, -3.0], [10.0, 0.9, -3.0]]},
    }


@pytest.fixture
def boxpush_run(monkeypatch, tmp_path):
    """run(box_end) -> (run_dir, {plot path: figure}): the experiment run as scripts/experiment runs it."""
    from pybullet_bridge.core.scenario import load_scenario
    from pybullet_bridge.report_scene import layout_of

    scene = layout_of(load_scenario(SCENARIO))
    figures = {}

    def keep(fig, path, *args, **kwargs):
        figures[Path(path).parent.name] = fig
        fig.savefig(path)
        return Path(path)

    def session(experiment_path, config_dir, run_dir, **kwargs):
        (run_dir / 'bags' / 'bag').mkdir(parents=True)
        return SimpleNamespace(bag=run_dir / 'bags' / 'bag', message='until met', condition_met=True, exit_code=0)

    def run(box_end):
        monkeypatch.setattr(boxpush, 'run_experiment', session)
        monkeypatch.setattr(boxpush, 'read_run', lambda bag, agents, tolerance: canned_run(box_end))
        monkeypatch.setattr(plots, 'bag_scene', lambda bag: scene)
        monkeypatch.setattr(plots, 'save', keep)
        run_dir = tmp_path / f'run_{box_end}'
        run_experiment(experiment_named('coalition-boxpush'),
                       ExperimentRequest(WORKSPACE / 'config', run_dir, log=lambda _line: None))
        return run_dir, figures

    yield run
    plots.plt.close('all')


def test_summary_opens_with_the_outcome(boxpush_run):
    run_dir, _ = boxpush_run(1.4)
    lines = (run_dir / 'summary.md').read_text().splitlines()
    assert lines[0] == ('- **coalition-boxpush: passed** — loss 0: box 0.1 m, navigation 0.1 m from the goal, '
                        '0 conflicts; loss 0.2: box 0.1 m, navigation 0.1 m from the goal, 0 conflicts')
    assert lines[:1] == outcome_markdown(run_outcomes(run_dir))      # as scripts/report RUN opens
    assert lines[2].startswith('| loss | coalitions |')


def test_a_failed_run_says_so_in_the_first_line(boxpush_run):
    run_dir, _ = boxpush_run(0.5)
    first = (run_dir / 'summary.md').read_text().splitlines()[0]
    assert first.startswith('- **coalition-boxpush: FAILED** — loss 0: box 1.0 m') and '(failed: box_reached)' in first


def test_trajectories_in_the_simulation_colours_over_the_scene(boxpush_run):
    run_dir, figures = boxpush_run(1.4)
    assert (run_dir / 'loss_0' / 'trajectories.png').is_file() and (run_dir / 'loss_0.2' / 'trajectories.png').is_file()
    ax = figures['loss_0'].axes[0]
    colours = {line.get_label(): to_rgb(line.get_color()) for line in ax.lines}
    assert colours['pusher_g1'] == pytest.approx((0.85, 0.15, 0.15))          # as in coalition_boxpush.yaml
    assert colours['pusher_r2'] == pytest.approx((0.15, 0.75, 0.15))
    box_path = next(line for line in ax.lines if line.get_label() == 'box (pushed)')
    assert to_rgb(box_path.get_color()) == pytest.approx((0.55, 0.3, 0.7)) and box_path.get_linestyle() == '--'
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert len(hatched) == 1 and hatched[0].get_facecolor()[:3] == pytest.approx((0.55, 0.3, 0.7))  # the box's start
    assert len(ax.patches) >= 5                                               # four walls and the box
    assert ax.get_xlim()[0] < -5.0 and ax.get_xlim()[1] > 5.0                 # the arena in view
