#!/bin/sh
# A run's recording (run.mcap) checked by @mcap/core and @foxglove/schemas
# (mcap_check.mjs): generates the posts-around flight (120 frames, 10 Hz) and maps
# it with zonemap-replay (single-threaded, then --pipeline) and with the daemon
# (outputs.record).
# Exit 77 (skipped, with the reason) when Node.js or the npm modules are missing.
#   run_mcap_check.sh SIM REPLAY DAEMON SOURCE_DIR WORK_DIR
set -e
sim=$1 replay=$2 daemon=$3 source=$4 work=$5
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
"$sim" posts-around "$work/seq" --width 640 --rate 10 --frames 120 >/dev/null
for mode in single pipeline; do
  flag=""
  [ "$mode" = pipeline ] && flag=--pipeline
  "$replay" "$work/seq" --config "$source/config/paper-flight1.yaml" --out "$work/$mode" \
    --quiet $flag >/dev/null
  echo "$mode:"
  node "$source/tests/js/mcap_check.mjs" "$work/$mode" || exit $?
done
printf '%s\n' "mapping: $source/config/paper-flight1.yaml" \
  "frames: {source: replay, sequence: $work/seq, rate_hz: 0}" \
  "poses: {source: sequence}" \
  "outputs:" \
  "  directory: $work/daemon" \
  "  record: {path: $work/daemon/run.mcap, depth_every: 10}" >"$work/vehicle.yaml"
"$daemon" --config "$work/vehicle.yaml" --quiet
echo "daemon:"
node "$source/tests/js/mcap_check.mjs" "$work/daemon"
