#!/bin/sh
# A white, textureless wall (flown at, passed beside, a tower above the horizon)
# never reads "free" in zonemap-replay --links's MAVLink log, decoded by
# node-mavlink (white_sectors.mjs); the map's sky pixels are printed beside it.
# Exit 77 (skipped, with the reason) when Node.js or node-mavlink is missing.
#   run_white_sectors.sh SIM REPLAY SOURCE_DIR WORK_DIR
set -e
sim=$1 replay=$2 source=$3 work=$4
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
for scene in white-wall white-wall-beside white-tower; do
  "$sim" "$scene" "$work/$scene" --width 640 --rate 5 >/dev/null
  "$replay" "$work/$scene" --config "$source/config/paper-flight2.yaml" --out "$work/$scene-run" \
    --quiet --no-record --links "$work/$scene-run/links" >/dev/null
  printf '%s: ' "$scene"
  grep -o '"pixels_sky[a-z_]*": [0-9]*' "$work/$scene-run/stats.json" | tr '\n' ' '
  node "$source/tests/js/white_sectors.mjs" "$work/$scene-run/links/obstacles.tlog" "$work/$scene" ||
    { status=$?; [ "$status" -eq 77 ] && exit 77; echo "FAILED: $scene"; exit 1; }
done
