from __future__ import annotations

import pytest

from collab_tools.core import report_plots
from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.core.report_plots import register_plot, registered_plots, unregister_plot, write_plots


@pytest.fixture
def custom_plot():
    calls = []

    def plot(bag, summary, out_dir):
        calls.append(bag)
        # a real plot would read its topics; check that it can
        topics = summary.topics_of_type('bridge_interfaces/msg/BodyStates')
        n = sum(1 for _ in read_messages(bag, topics))
        path = out_dir / 'custom.png'
        path.write_bytes(b'png' * n)
        return [path]

    register_plot('test_custom', {'bridge_interfaces/BodyStates'}, plot)
    yield calls
    unregister_plot('test_custom')


def test_builtins_registered():
    plots = registered_plots()
    assert plots['message_rates'] == set()
    assert plots['trajectories'] == {'bridge_interfaces/msg/BodyStates'}
    assert plots['velocities'] == {'geometry_msgs/msg/Twist'}


def test_custom_plot_called_exactly_when_type_present(tmp_path, make_bag, custom_plot):
    with_states = make_bag(tmp_path / 'with', n=3)
    without = make_bag(tmp_path / 'without', n=3, topics=('/chatter',))

    written = write_plots(without, summarize_bag(without), tmp_path / 'out_without')
    assert custom_plot == []
    assert [p.name for p in written] == ['message_rates.png']  # no Twist, no BodyStates

    written = write_plots(with_states, summarize_bag(with_states), tmp_path / 'out_with')
    assert custom_plot == [with_states]
    names = sorted(p.name for p in written)
    assert names == ['custom.png', 'message_rates.png', 'trajectories.png', 'velocities.png']
    assert (tmp_path / 'out_with' / 'custom.png').read_bytes() == b'png' * 3
    for p in written:
        assert p.is_file() and p.stat().st_size > 0


def test_failing_plot_does_not_sink_the_others(tmp_path, make_bag, capsys):
    bag = make_bag(tmp_path / 'bag', n=2, topics=('/chatter',))

    def broken(bag, summary, out_dir):
        raise RuntimeError('kaputt')

    register_plot('test_broken', set(), broken)
    try:
        written = write_plots(bag, summarize_bag(bag), tmp_path / 'out')
        assert [p.name for p in written] == ['message_rates.png']
        assert 'kaputt' in capsys.readouterr().err
        with pytest.raises(report_plots.PlotError, match='kaputt'):
            write_plots(bag, summarize_bag(bag), tmp_path / 'out2', strict=True)
    finally:
        unregister_plot('test_broken')


def test_trajectory_plot_uses_only_mobile_robots(tmp_path, make_bag, monkeypatch):
    bag = make_bag(tmp_path / 'bag', n=5)
    plotted = []
    real_plot = report_plots.plt.Axes.plot

    def spy(self, *args, **kwargs):
        if kwargs.get('label'):
            plotted.append(kwargs['label'])
        return real_plot(self, *args, **kwargs)

    monkeypatch.setattr(report_plots.plt.Axes, 'plot', spy)
    paths = report_plots.plot_trajectories(bag, summarize_bag(bag), tmp_path)
    assert [p.name for p in paths] == ['trajectories.png']
    assert 'robot_1' in plotted and 'robot_2' in plotted and 'box_1' not in plotted
