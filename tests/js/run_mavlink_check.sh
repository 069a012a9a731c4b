#!/bin/sh
# The daemon's MAVLink checked by node-mavlink against ground truth: generates the
# posts-around flight (120 frames, 10 Hz), runs mavlink_ground_truth.mjs on it.
# Exit 77 (skipped, with the reason) when Node.js or node-mavlink is missing.
#   run_mavlink_check.sh SIM DAEMON SOURCE_DIR WORK_DIR
set -e
sim=$1 daemon=$2 source=$3 work=$4
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
"$sim" posts-around "$work/seq" --width 640 --rate 10 --frames 120 >/dev/null
exec node "$source/tests/js/mavlink_ground_truth.mjs" "$daemon" "$work/seq" \
  "$source/config/paper-flight1.yaml" "$work/run"
