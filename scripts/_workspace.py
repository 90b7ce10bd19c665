"""Bootstrap shared by the Python scripts in scripts/.

A fresh clone needs nothing but `scripts/demo` (or another script): this runs
scripts/setup when needed and re-executes the script inside the workspace
environment (scripts/env.sh), so imports of rclpy and the workspace packages work.
"""

import os
import subprocess
import sys
from pathlib import Path

WORKSPACE = Path(__file__).resolve().parents[1]
CONFIG_DIR = WORKSPACE / 'config'


def ensure_workspace_env() -> None:
    if os.environ.get('COLLAB_WS_ENV') == str(WORKSPACE):
        return
    setup = subprocess.run(['bash', str(WORKSPACE / 'scripts' / 'setup'), '--quiet'])
    if setup.returncode != 0:
        sys.exit(setup.returncode)
    script = str(Path(sys.argv[0]).resolve())
    os.execvp('bash', ['bash', '-c', 'source "$0/scripts/env.sh" && exec python "$@"',
                       str(WORKSPACE), script, *sys.argv[1:]])
