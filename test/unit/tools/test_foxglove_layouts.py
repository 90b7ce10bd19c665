"""The shipped Foxglove layouts (config/foxglove/) are what scripts/tools/foxglove_layouts.py builds,
one per marker source, each with a 3D panel on that source's markers, the camera and plots."""
import json
import runpy
from pathlib import Path

from collab_tools.core.marker_specs import MARKER_SOURCES

WORKSPACE = Path(__file__).resolve().parents[3]
TOOL = WORKSPACE / 'scripts' / 'tools' / 'foxglove_layouts.py'


def panels(node):
    if node.get('type') == 'panel':
        yield node
    for item in node.get('items', []):
        yield from panels(item['content'])


def test_the_layouts_are_up_to_date_and_one_per_source():
    tool = runpy.run_path(str(TOOL))
    assert tool['main'](['--check']) == 0
    assert sorted(p.stem for p in (WORKSPACE / 'config' / 'foxglove').glob('*.json')) == sorted(MARKER_SOURCES)
    for name in MARKER_SOURCES:
        layout = json.loads((WORKSPACE / 'config' / 'foxglove' / f'{name}.json').read_text())
        kinds = {p['panelType']: p for p in panels(layout['content'])}
        assert set(kinds) >= {'ThreeDee', 'Image', 'Plot', 'RawMessages'}
        assert f'/markers/{name}' in kinds['ThreeDee']['config']['topics']
        assert kinds['ThreeDee']['config']['followTf'] == 'world'
        assert kinds['Image']['config']['imageMode']['imageTopic'] == '/top_camera/image_raw/compressed'
        assert len(kinds['Plot']['config']['paths']) >= 3
