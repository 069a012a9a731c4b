#!/bin/sh
# zonemap-replay --links's MAVLink telemetry log read by node-mavlink
# (tlog_check.mjs), on the posts-through flight (80 frames, 10 Hz).
# Exit 77 (skipped, with the reason) when Node.js or node-mavlink is missing.
#   run_tlog_check.sh SIM REPLAY SOURCE_DIR WORK_DIR
set -e
sim=$1 replay=$2 source=$3 work=$4
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
"$sim" posts-through "$work/seq" --width 640 --rate 10 --frames 80 >/dev/null
"$replay" "$work/seq" --config "$source/config/paper-flight3.yaml" --out "$work/run" --quiet \
  --no-record --links "$work/run/links" >/dev/null
node "$source/tests/js/tlog_check.mjs" "$work/run/links/obstacles.tlog" px4
exec node "$source/tests/js/tlog_check.mjs" "$work/run/links/obstacles-ardupilot.tlog" ardupilot
