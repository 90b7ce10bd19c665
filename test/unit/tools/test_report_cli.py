from __future__ import annotations

import json

from collab_tools.report_cli import main


def test_report_on_run_dir(tmp_path, make_bag, capsys):
    run = tmp_path / 'run_1'
    make_bag(run / 'bags' / 'sim', n=11)
    make_bag(run / 'bags' / 'other', n=4, topics=('/chatter',))
    assert main([str(run)]) == 0
    out = capsys.readouterr().out
    report_dir = run / 'report'
    assert out.strip().splitlines()[-1].endswith(str(report_dir.resolve()))
    assert '/sim/body_states' in out and 'rate Hz' in out

    data = json.loads((report_dir / 'report.json').read_text())
    bags = {b['name']: b for b in data['bags']}
    assert set(bags) == {'bags/sim', 'bags/other'}
    sim = bags['bags/sim']
    assert {t['topic']: t['count'] for t in sim['topics']} == {
        '/chatter': 11, '/robot_1/cmd_vel': 11, '/sim/body_states': 11}
    assert {t['topic']: t['type'] for t in sim['topics']}['/sim/body_states'] == 'bridge_interfaces/msg/BodyStates'
    assert all(abs(t['rate_hz'] - 10.0) < 1e-9 for t in sim['topics'])
    assert abs(sim['duration_s'] - 1.0) < 1e-9
    assert sim['message_count'] == 33
    assert sorted(p.rsplit('/', 1)[-1] for p in sim['plots']) == [
        'message_rates.png', 'trajectories.png', 'velocities.png']
    assert [p.rsplit('/', 1)[-1] for p in bags['bags/other']['plots']] == ['message_rates.png']
    for bag in data['bags']:
        for plot in bag['plots']:
            png = report_dir / plot
            assert png.is_file() and png.stat().st_size > 0
            assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'

    md = (report_dir / 'report.md').read_text()
    assert '| topic | type | count | rate [Hz] |' in md
    assert '`/sim/body_states`' in md
    for plot in sim['plots']:
        assert f']({plot})' in md


def test_report_single_bag_default_dir_and_out(tmp_path, make_bag, capsys):
    bag = make_bag(tmp_path / 'run' / 'bag_x', n=3)
    assert main([str(bag)]) == 0
    default_dir = tmp_path / 'run' / 'report' / 'bag_x'
    assert (default_dir / 'report.json').is_file() and (default_dir / 'velocities.png').stat().st_size > 0
    assert capsys.readouterr().out.strip().splitlines()[-1].endswith(str(default_dir.resolve()))

    out = tmp_path / 'elsewhere'
    assert main([str(bag), '--out', str(out)]) == 0
    data = json.loads((out / 'report.json').read_text())
    assert data['bags'][0]['message_count'] == 9
    assert (out / 'report.md').stat().st_size > 0
    assert (out / 'trajectories.png').stat().st_size > 0

    # a file inside the bag counts as the bag
    assert main([str(bag / 'metadata.yaml'), '--out', str(tmp_path / 'via_file')]) == 0
    assert json.loads((tmp_path / 'via_file' / 'report.json').read_text())['bags'][0]['name'] == 'bag_x'


def test_report_no_bag_exits_2(tmp_path, capsys):
    (tmp_path / 'empty_run').mkdir()
    assert main([str(tmp_path / 'empty_run')]) == 2
    err = capsys.readouterr().err
    assert 'no bag found' in err
    assert not (tmp_path / 'empty_run' / 'report').exists()
    assert main([str(tmp_path / 'nowhere')]) == 2


def test_plot_plugins_come_from_the_ament_index():
    # sgcm lists sgcm.experiments.report_plots under the collab_report_plots resource.
    from collab_tools.core.report_plots import registered_plots
    from collab_tools.report_cli import load_plot_plugins

    assert 'sgcm.experiments.report_plots' in load_plot_plugins()
    assert registered_plots()['sgcm_rounds'] == {'sgcm_interfaces/msg/Guidance'}
