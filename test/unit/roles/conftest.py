"""Make ``role_engine`` importable from the source tree when the workspace is not built or sourced.

The role engine core reads its YAML files with the shared field readers (``collab_tools.core.fields``)
and map images with the bridge's pure occupancy-map reader, so both source trees are added the same way.
"""
import importlib.util
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[3] / 'src'
PACKAGE_ROOT = SRC / 'role_engine'

if importlib.util.find_spec('role_engine') is None:
    sys.path.insert(0, str(PACKAGE_ROOT))
if importlib.util.find_spec('pybullet_bridge') is None:
    sys.path.insert(0, str(SRC / 'pybullet_bridge'))
if importlib.util.find_spec('collab_tools') is None:  # the shared field readers and camera model
    sys.path.insert(0, str(SRC / 'collab_tools'))
