"""Make ``pybullet_bridge`` importable when the workspace is not built or sourced."""
import importlib.util
import sys
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parents[3] / 'src' / 'pybullet_bridge'

if importlib.util.find_spec('pybullet_bridge') is None:
    sys.path.insert(0, str(PACKAGE_ROOT))
if importlib.util.find_spec('collab_tools') is None:  # the shared camera model
    sys.path.insert(0, str(PACKAGE_ROOT.parent / 'collab_tools'))
