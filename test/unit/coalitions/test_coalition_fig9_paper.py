"""coalition-fig9 beside the paper: the paper's Fig. 9 values (from its text) in their own columns, the
paper's Eq. (1) gap terms, paper_notes.md and the figure, from a recorded run's results (no simulation)."""
from coalition_agents.experiments.fig9 import PAPER_FIG9, eq1_delays, eq1_gap_terms, fig9_markdown, fig9_notes, plot_fig9


def column_results(times: dict[int, float]) -> dict:
    runs = [{'robots': n, 'time_s': t, 'formed_s': t + 0.8, 'search_time_s': 6.0, 'state': 'committed',
             'includes_all_robots': True, 'members': [f'robot_{k}' for k in range(1, n + 1)], 'cost': 9.5 * n,
             'messages': 100 * n, 'ros_messages': 20 * n} for n, t in times.items()]
    return {'link': {'preset': 'paper_fig9', 'loss_probability': 0.0}, 'runs': runs,
            'paper_time_s': {'10': 28.0}}


def test_reference_values_are_the_papers_text():
    # iq_asymtre_coalitions.txt, Section V-A-4: "about 30 s" for ten robots (five runs), "the 28th second",
    # T_G = T_C = 0.2 s, T_D ~ N(3.85 ms, 5.05 ms), P <= 11, S <= 10, a 60-s gap, stable after the 90th second
    assert PAPER_FIG9['mean_of_runs_s'] == {10: 30.0} and PAPER_FIG9['runs_averaged'] == 5
    assert PAPER_FIG9['plotted_run_s'] == {10: 28.0}
    assert (PAPER_FIG9['t_g_s'], PAPER_FIG9['t_c_s'], PAPER_FIG9['link_delay_ms']) == (0.2, 0.2, (3.85, 5.05))
    assert (PAPER_FIG9['p_bound'], PAPER_FIG9['s_bound']) == (11, 10)


def test_eq1_terms():
    # ten robots: N = 9 hops; 10 robots x T_G + 2 x 9 x T_C
    assert eq1_gap_terms(10, 0.2, 0.2) == 10 * 0.2 + 18 * 0.2
    assert eq1_gap_terms(10, 0.2, 0.2, p=11, s=10) == 10 * 110 * 0.2 + 18 * 0.2
    assert eq1_gap_terms(10, 0.0, 0.0) == 0.0
    assert eq1_delays(10, 0.00385) == 18 * 0.00385


def test_table_and_notes_hold_the_papers_values(tmp_path):
    results = column_results({2: 0.05, 10: 0.47, 20: 4.4})
    table = fig9_markdown(results, {'passed': True})
    header = next(line for line in table.splitlines() if line.startswith('| robots |'))
    assert 'paper: mean of 5 runs (s)' in header and 'paper: plotted run (s)' in header
    ten = next(line for line in table.splitlines() if line.startswith('| 10 |'))
    assert '| 0.470 | ~30 | 28 | >= 5.6 |' in ten
    assert '| 2 | 0.050 | - | - | >= 0.8 |' in table   # 2 x T_G + 2 x 1 x T_C
    assert 'paper_notes.md' in table
    notes = fig9_notes(results)
    assert 'about 30 s' in notes and '28th second' in notes and 'T_G = T_C = 0.2 s' in notes
    assert '| 10 | 0.470 | ~30 | 28 | 5.6 | 224 | 69 |' in notes
    assert 'the time grows with the column here (0.050 s for 2 robots, 4.400 s for 20)' in notes
    assert '3 of 3 columns formed a coalition of all their robots' in notes
    assert 'grows with the column overall' in fig9_notes(column_results({2: 0.05, 8: 0.5, 9: 0.4, 20: 4.4}))
    assert 'does NOT grow with the column' in fig9_notes(column_results({2: 1.0, 10: 0.47}))
    plot_fig9(results, tmp_path)
    assert (tmp_path / 'fig9_time.png').read_bytes()[:4] == b'\x89PNG'
