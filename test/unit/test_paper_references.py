"""Each paper is named the same everywhere a clone shows it: the core's ``__init__`` docstring (its paper map),
CITATION.cff and the README's Papers section give the paper's own title and authors."""
import ast
import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
CORES = {  # package -> the paper's short name (the file names the project's notes use)
    'sgcm': 'stackelberg_guidance_sgcm',
    'role_engine': 'role_engine_gp_inference',
    'coalition_agents': 'iq_asymtre_coalitions',
}


def flat(text: str) -> str:
    return re.sub(r'\s+', ' ', text)


def references() -> dict[str, dict]:
    """short name -> CITATION.cff reference (the note names the package)."""
    found = {}
    for ref in yaml.safe_load((ROOT / 'CITATION.cff').read_text())['references']:
        package = re.search(r'\(src/(\w+)\)', ref['notes']).group(1)
        found[CORES[package]] = ref
    return found


def test_each_core_docstring_gives_the_citation_title_and_authors():
    refs = references()
    assert set(refs) == set(CORES.values())
    for package, short in CORES.items():
        doc = flat(ast.get_docstring(ast.parse((ROOT / 'src' / package / package / 'core' / '__init__.py').read_text())))
        ref = refs[short]
        assert f'"{ref["title"]}' in doc, (package, ref['title'])          # a trailing comma may sit inside the quotes
        for author in ref['authors']:
            initials = '. '.join(part[0] for part in re.split(r'[ -]', author['given-names'])) + '.'
            assert author['family-names'] in doc, (package, author)
            assert initials.replace('. ', '.-', 1) in doc or initials in doc, (package, author, initials)
        assert short in doc and 'CITATION.cff' in doc and 'shared/papers' not in doc


def test_the_readme_papers_section_gives_the_same_titles_and_authors():
    readme = flat((ROOT / 'README.md').read_text())
    for short, ref in references().items():
        entry = readme[readme.index(f'(`{short}`'):][:600]
        assert f'"{ref["title"]}"' in entry, short
        for author in ref['authors']:
            assert f'{author["given-names"]} {author["family-names"]}' in entry, (short, author)
