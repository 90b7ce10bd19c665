"""The repository carries its licence and citation: LICENSE is the Apache-2.0 text every package declares
(except interfaces/tf2_msgs, ROS's BSD-3-Clause definitions), CITATION.cff cites the workspace and the
three papers it follows."""
from pathlib import Path
import re

import yaml

ROOT = Path(__file__).resolve().parents[2]
PAPERS = {
    'Stackelberg Strategic Guidance for Heterogeneous Robots Collaboration':
        ['Yuhan Zhao', 'Baichuan Huang', 'Jingjin Yu', 'Quanyan Zhu'],
    'Role Engine Implementation for a Continuous and Collaborative Multi-Robot System':
        ['Behzad Akbari', 'Zikai Wang', 'Haibin Zhu', 'Lucas Wan', 'Ryan Adderson', 'Ya-Jun Pan'],
    'IQ-ASyMTRe: Forming Executable Coalitions for Tightly Coupled Multirobot Tasks':
        ['Yu Zhang', 'Lynne E. Parker'],
}


def package_licences() -> dict[str, str]:
    found = {}
    for manifest in sorted([*ROOT.glob('src/*/package.xml'), *ROOT.glob('interfaces/*/package.xml')]):
        licences = re.findall(r'<license>([^<]+)</license>', manifest.read_text())
        found[manifest.parent.name] = ', '.join(licences)
    return found


def test_license_is_the_apache_text_the_packages_declare():
    text = (ROOT / 'LICENSE').read_text()
    assert text.split()[:4] == ['Apache', 'License', 'Version', '2.0,']
    assert 'TERMS AND CONDITIONS FOR USE, REPRODUCTION, AND DISTRIBUTION' in text
    assert 'END OF TERMS AND CONDITIONS' in text and 'APPENDIX: How to apply the Apache License' in text
    licences = package_licences()
    assert licences, 'package manifests found'
    others = {name: licence for name, licence in licences.items() if licence != 'Apache-2.0'}
    # tf2_msgs is rebuilt from ros2/geometry2's public definitions and keeps their licence
    assert others == {'tf2_msgs': 'BSD-3-Clause'}


def test_citation_file_cites_the_workspace_and_the_three_papers():
    citation = yaml.safe_load((ROOT / 'CITATION.cff').read_text())
    assert citation['cff-version'] == '1.2.0' and citation['type'] == 'software'
    assert citation['license'] == 'Apache-2.0' and citation['title'] and citation['authors']
    references = {ref['title']: ref for ref in citation['references']}
    assert set(references) == set(PAPERS)
    for title, authors in PAPERS.items():
        ref = references[title]
        assert ref['type'] == 'article'
        assert [f"{a['given-names']} {a['family-names']}" for a in ref['authors']] == authors
    assert references['IQ-ASyMTRe: Forming Executable Coalitions for Tightly Coupled Multirobot Tasks'][
        'journal'] == 'IEEE Transactions on Robotics'


def readme_link_targets() -> list[str]:
    """Relative targets of the README's Markdown links (web addresses and in-page anchors left out)."""
    text = (ROOT / 'README.md').read_text()
    targets = re.findall(r'\]\(([^)\s]+)\)', text)
    return [t.split('#', 1)[0] for t in targets
            if not re.match(r'[a-z]+://|mailto:|#', t) and t.split('#', 1)[0]]


def test_readme_links_only_to_what_a_clone_contains():
    text = (ROOT / 'README.md').read_text()
    outside = [line.strip() for line in text.splitlines() if re.search(r'\.\./shared|/work/|`issues`', line)]
    assert not outside, f'README points outside the repository: {outside[:5]}'
    missing = [t for t in readme_link_targets() if not (ROOT / t).exists()]
    assert not missing, f'README links to files a clone does not have: {missing}'
