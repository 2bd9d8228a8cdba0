# Source this file (bash) to use the workspace built by `make setup` in the pip environment:
#   source env.sh
# It activates .venv (ROS 2 Jazzy from PyPI), overlays ros_ws/install (the colcon build) and puts
# tools/pip-env on PATH, whose `ros2` understands `ros2 run PKG EXE [ARGS]` (ros2cli is not on PyPI).
# On a stock ROS 2 Jazzy install use instead:
#   source /opt/ros/jazzy/setup.bash && source ros_ws/install/setup.bash

_tric_root="$(builtin cd "$(dirname "${BASH_SOURCE[0]}")" > /dev/null && pwd)"
if [ ! -f "$_tric_root/.venv/bin/activate" ] || [ ! -f "$_tric_root/ros_ws/install/local_setup.bash" ]; then
  echo "env.sh: the workspace is not built yet; run 'make setup' in $_tric_root first" >&2
  return 1 2>/dev/null || exit 1
fi
# shellcheck disable=SC1091
source "$_tric_root/.venv/bin/activate"
export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$VIRTUAL_ENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
# shellcheck disable=SC1091
source "$_tric_root/ros_ws/install/local_setup.bash"
# The wheels' ros_wheels_bootstrapper re-executes every Python process once to set LD_LIBRARY_PATH;
# setting it here, with its guard, saves that second start.
for _tric_lib in "$VIRTUAL_ENV"/lib/python3.*/site-packages/ros_*.libs "$VIRTUAL_ENV/lib"; do
  case ":${LD_LIBRARY_PATH:-}:" in *":$_tric_lib:"*) ;; *) export LD_LIBRARY_PATH="$_tric_lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}";; esac
done
export _ROS_WHEELS_BOOTSTRAP_COMPLETE=1
export PATH="$_tric_root/tools/pip-env:$PATH"
export TRIC_ROOT="$_tric_root"
unset _tric_root _tric_lib
