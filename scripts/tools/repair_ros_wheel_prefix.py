#!/usr/bin/env python3
"""Rewrite the wheel builder's hard-coded paths inside a pip-installed ROS prefix.

The ROS 2 Jazzy wheels on PyPI install a ROS prefix into the virtualenv, but some
of their files still name the machine they were built on (/opt/python/cp311-cp311):
  * cmake export files of the Python typesupport name its Python include dir and
    numpy include dir, so building our own interface packages fails to find them;
  * ament index ``parent_prefix_path`` markers name it as the parent prefix.
This tool rewrites those to this interpreter's include dir, numpy.get_include() and
the virtualenv prefix. It is idempotent and prints what it changed.
"""

import argparse
import os
import sys
import sysconfig
from pathlib import Path

BUILDER_PREFIX = '/opt/python/cp311-cp311'
BUILDER_PYTHON_INCLUDE = BUILDER_PREFIX + '/include/python3.11'
BUILDER_NUMPY_INCLUDE = BUILDER_PREFIX + '/lib/python3.11/site-packages/numpy/_core/include'


def replacements(prefix: Path) -> list[tuple[str, str]]:
    import numpy  # imported here: only needed when repairing

    # Longest first, so the prefix rule does not eat the more specific ones.
    return [
        (BUILDER_NUMPY_INCLUDE, numpy.get_include()),
        (BUILDER_PYTHON_INCLUDE, sysconfig.get_paths()['include']),
        (BUILDER_PREFIX, str(prefix)),
    ]


def candidate_files(prefix: Path):
    share = prefix / 'share'
    yield from share.glob('*/cmake/*.cmake')
    yield from (share / 'ament_index' / 'resource_index').glob('*/*')


def repair(prefix: Path, dry_run: bool = False) -> list[Path]:
    rules = replacements(prefix)
    changed = []
    for path in candidate_files(prefix):
        if not path.is_file():
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        if BUILDER_PREFIX not in text:
            continue
        for old, new in rules:
            text = text.replace(old, new)
        if not dry_run:
            path.write_text(text)
        changed.append(path)
    return changed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--prefix', default=os.environ.get('VIRTUAL_ENV', sys.prefix),
                        help='ROS prefix installed by the wheels (default: the active venv)')
    parser.add_argument('--dry-run', action='store_true', help='only list what would change')
    args = parser.parse_args(argv)
    prefix = Path(args.prefix).resolve()
    if not (prefix / 'share' / 'ament_index').is_dir():
        print(f'repair_ros_wheel_prefix: {prefix} holds no ROS prefix (no share/ament_index)',
              file=sys.stderr)
        return 2
    changed = repair(prefix, args.dry_run)
    verb = 'would rewrite' if args.dry_run else 'rewrote'
    print(f'repair_ros_wheel_prefix: {verb} builder paths in {len(changed)} files under {prefix}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
