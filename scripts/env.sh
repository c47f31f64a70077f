# Source me: `source scripts/env.sh`. Gives a shell where `ros2 run foos_sim sim_node` works.
# Where a real ROS 2 Jazzy is already sourced, its ros2cli and Python packages win; the venv only
# adds what is missing, and the stand-in ros2 stays off PATH.
_foos_root=$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)
if [ ! -f "$_foos_root/ros2_ws/install/setup.bash" ]; then
  echo "env.sh: the workspace is not built; run $_foos_root/scripts/setup first" >&2
  return 1 2>/dev/null || exit 1
fi
_foos_nounset=$([[ $- == *u* ]] && echo 1 || true)
set +u
# shellcheck disable=SC1091
source "$_foos_root/.venv/bin/activate"
export AMENT_PREFIX_PATH=${AMENT_PREFIX_PATH:+$AMENT_PREFIX_PATH:}$VIRTUAL_ENV
# shellcheck disable=SC1091
source "$_foos_root/ros2_ws/install/setup.bash"
if ! command -v ros2 >/dev/null 2>&1; then
  export PATH="$PATH:$_foos_root/.venv/standin/bin"
fi
# Fast DDS' shared-memory transport prints errors where /dev/shm is small; UDP on loopback always works.
export FASTDDS_BUILTIN_TRANSPORTS=${FASTDDS_BUILTIN_TRANSPORTS:-UDPv4}
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
export MUJOCO_GL=${MUJOCO_GL:-egl}
export FOOS_ROOT=$_foos_root
[ -n "$_foos_nounset" ] && set -u
unset _foos_nounset
