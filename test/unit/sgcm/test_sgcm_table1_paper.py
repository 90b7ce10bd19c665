"""sgcm-table1 beside the paper: the paper's Table I values in their own columns, row by row in kind,
and paper_notes.md (the cases are the project's own, the utility scale differs)."""
import json
import re
from pathlib import Path

import pytest

from collab_tools.experiments.api import ExperimentRequest, run_experiment
from sgcm.experiments import EXPERIMENTS
from sgcm.experiments.table1_paper import PAPER_TABLE1, paper_row, rounds_relation, utility_relation

CONFIG_DIR = Path(__file__).resolve().parents[3] / 'config'
PAPERS_TABLE1 = {  # Table I of stackelberg_guidance_sgcm.txt, as printed
    1: ('No', '> 7', 283.5, 'Yes', 6, 309), 2: ('No', '> 7', 288.5, 'Yes', 6, 313.5),
    3: ('No', '> 7', 300.5, 'Yes', 6, 315), 4: ('Yes', '5', 278, 'Yes', 5, 283),
    5: ('No', '> 8', 306.5, 'Yes', 7, 344.5), 6: ('Yes', '6', 289.5, 'Yes', 5, 306.5),
    7: ('Yes', '5', 297.5, 'Yes', 5, 298.5), 8: ('Yes', '3', 219.5, 'Yes', 3, 219.5),
    9: ('Yes', '7', 249, 'Yes', 5, 275), 10: ('Yes', '7', 277.5, 'Yes', 6, 301),
}


@pytest.fixture(scope='module')
def table1(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp('sgcm-table1')
    experiment = next(e for e in EXPERIMENTS if e.name == 'sgcm-table1')
    run_experiment(experiment, ExperimentRequest(CONFIG_DIR, run_dir, options={'only': ['case_1', 'case_4', 'case_8']},
                                                 log=lambda _line: None))
    return json.loads((run_dir / 'results.json').read_text()), run_dir


def test_reference_rows_are_the_papers_table():
    assert len(PAPER_TABLE1) == 10
    for row in PAPER_TABLE1:
        status, rounds, utility, sgcm_status, sgcm_rounds, sgcm_utility = PAPERS_TABLE1[row.case]
        assert (row.greedy_completed, row.greedy_rounds, row.greedy_utility) == (status == 'Yes', rounds, utility)
        assert (row.sgcm_completed, row.sgcm_rounds, row.sgcm_utility) == (sgcm_status == 'Yes', sgcm_rounds,
                                                                           sgcm_utility)
    assert [paper_row(f'case_{k}').case for k in range(1, 11)] == list(range(1, 11))
    assert paper_row('grid_4x4') is None and paper_row('case_11') is None


def test_relations_in_kind():
    assert rounds_relation(False, 7, 6) == 'greedy stuck'
    assert [rounds_relation(True, g, s) for g, s in ((6, 5), (5, 5), (4, 5))] == ['SGCM fewer', 'equal', 'SGCM more']
    assert [utility_relation(g, s) for g, s in ((1.0, 2.0), (2.0, 2.0), (2.0, 1.0))] == [
        'SGCM higher', 'equal', 'SGCM lower']
    assert [r.sgcm_rounds_vs_greedy for r in PAPER_TABLE1] == [
        'greedy stuck', 'greedy stuck', 'greedy stuck', 'equal', 'greedy stuck', 'SGCM fewer', 'equal', 'equal',
        'SGCM fewer', 'SGCM fewer']


def test_table_holds_the_papers_columns_beside_ours(table1):
    results, run_dir = table1
    table = (run_dir / 'table1.md').read_text()
    rows = {line.split('|')[1].strip(): line for line in table.splitlines() if line.startswith('| case_')}
    side = [line for line in table.splitlines() if line.startswith('| case_1 |') and '(283.5)' in line]
    assert len(side) == 1, 'case_1 is printed beside the paper\'s greedy utility 283.5'
    assert '(309)' in side[0] and '(> 7)' in side[0] and '(6)' in side[0]
    assert any('(219.5)' in line for line in table.splitlines() if line.startswith('| case_8 |'))
    assert 'case_4' in rows
    assert "our cases are the project's own" in table
    comparison = results['paper_comparison']
    assert comparison['compared_cases'] == 3 and comparison['cases_are_the_papers'] is False
    by_case = {r['case']: r for r in comparison['rows']}
    assert by_case['case_1']['paper']['greedy_utility'] == 283.5 and by_case['case_1']['paper']['sgcm_utility'] == 309
    assert by_case['case_1']['ours']['rounds'] == 'greedy stuck' and by_case['case_1']['matches_paper_in_kind']
    # the row's verdict follows from the relations, not from the case name
    for row in comparison['rows']:
        o, p = row['ours'], row['paper']
        assert row['matches_paper_in_kind'] == (o['greedy_completed'] == p['greedy_completed']
                                                and o['rounds'] == p['rounds'] and o['utility'] == p['utility'])


def test_notes_explain_cases_and_utility_scale(table1):
    results, run_dir = table1
    notes = (run_dir / 'paper_notes.md').read_text()
    case_1 = next(r for r in results['paper_comparison']['rows'] if r['case'] == 'case_1')
    assert "The cases are the project's own" in notes and 'Fig. 2' in notes
    assert f"greedy {case_1['ours']['greedy_utility']:.1f} / SGCM {case_1['ours']['sgcm_utility']:.1f} here, " \
           '283.5 / 309 in the paper' in notes
    assert 'The utility scale differs' in notes and '--cases FILE' in notes
    # the paper's per-round utility is printed beside ours for every compared case
    assert re.search(r'\| case_8 \| 3 \| [\d.]+ \| [\d.]+ \| [\d.]+ \| 73\.2 \|', notes)
