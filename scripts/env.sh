# Source this file (bash) to use the workspace: `source scripts/env.sh`.
# It activates .venv, puts ROS 2 Jazzy (apt install or the venv's wheels) and the
# built workspace overlay on the environment, and sets local-only discovery.
# `--no-overlay` skips the workspace overlay (used by scripts/setup before building).

_collab_ws=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# ROS's and colcon's setup files read unset variables; callers may run with `set -u`.
case $- in *u*) _collab_nounset=1; set +u ;; *) _collab_nounset=0 ;; esac

if [ ! -f "$_collab_ws/.venv/bin/activate" ]; then
  echo "scripts/env.sh: $_collab_ws/.venv does not exist; run scripts/setup first" >&2
  [ "$_collab_nounset" = 1 ] && set -u
  return 1 2>/dev/null || exit 1
fi

if [ -f /opt/ros/jazzy/setup.bash ] && [ "${COLLAB_ROS_FROM:-}" != wheels ]; then
  # shellcheck disable=SC1091
  source /opt/ros/jazzy/setup.bash
  # shellcheck disable=SC1091
  source "$_collab_ws/.venv/bin/activate"
else
  # shellcheck disable=SC1091
  source "$_collab_ws/.venv/bin/activate"
  # The wheels install a ROS prefix into the venv; ament and cmake must be told.
  case ":${AMENT_PREFIX_PATH:-}:" in *":$VIRTUAL_ENV:"*) ;;
    *) export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;; esac
  case ":${CMAKE_PREFIX_PATH:-}:" in *":$VIRTUAL_ENV:"*) ;;
    *) export CMAKE_PREFIX_PATH="$VIRTUAL_ENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}" ;; esac
  case ":${LD_LIBRARY_PATH:-}:" in *":$VIRTUAL_ENV/lib:"*) ;;
    *) export LD_LIBRARY_PATH="$VIRTUAL_ENV/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" ;; esac
  export ROS_DISTRO=jazzy ROS_VERSION=2 ROS_PYTHON_VERSION=3
fi

export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
# Keep experiments on this machine unless the user asks otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"

if [ "${1:-}" != --no-overlay ]; then
  if [ -f "$_collab_ws/install/local_setup.bash" ]; then
    # shellcheck disable=SC1091
    source "$_collab_ws/install/local_setup.bash"
  else
    echo "scripts/env.sh: the workspace is not built yet; run scripts/setup" >&2
  fi
  export COLLAB_WS_ENV="$_collab_ws"
fi
[ "$_collab_nounset" = 1 ] && set -u
unset _collab_ws _collab_nounset
