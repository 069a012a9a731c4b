#!/bin/sh
# ArduPilot (software in the loop) reading the daemon's obstacles, checked by
# sitl_proximity.mjs on the posts-staggered flight (240 frames ending in a 10 s hover, 10 Hz, the
# outdoor config), then a daemon taking its poses from ArduPilot's EKF, in a
# private network namespace: ArduPilot listens on every
# interface. Exit 77 (skipped, with the reason) without ArduPilot's SITL build
# (../shared/sitl beside the clone), Node.js, node-mavlink or a namespace.
# With MESSAGES 2d the daemon sends OBSTACLE_DISTANCE's sectors (PX4's message).
#   run_sitl_proximity.sh SIM DAEMON SOURCE_DIR SITL_DIR WORK_DIR [MESSAGES]
set -e
sim=$1 daemon=$2 source=$3 sitl=$4 work=$5 messages=${6:-3d}
if [ ! -x "$sitl/arducopter" ]; then
  echo "SKIP: no ArduPilot SITL build at $sitl (the shared folder beside the clone holds it)"
  exit 77
fi
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
mkdir -p "$work"
"$sim" posts-staggered "$work/seq" --width 640 --rate 10 >/dev/null
# Frames for the daemon that takes its poses from ArduPilot's EKF (NED).
"$sim" posts-staggered "$work/seq-ned" --width 320 --rate 10 --frames 60 >/dev/null
echo "world_z_up: false" >>"$work/seq-ned/camera.yaml"
exec "$source/tests/netns/in_private_netns.sh" node "$source/tests/js/sitl_proximity.mjs" \
  "$sitl" "$daemon" "$work/seq" "$source/config/paper-flight2.yaml" "$work/run" "$work/seq-ned" \
  "$messages"
