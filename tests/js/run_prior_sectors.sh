#!/bin/sh
# A prior map in the flight controller's sectors from the first message
# (prior_sectors.mjs, node-mavlink): the posts flight with its camera turned
# backwards, the two posts as a prior map, zonemap-replay --links.
# Exit 77 (skipped, with the reason) when Node.js or node-mavlink is missing.
#   run_prior_sectors.sh SIM REPLAY SOURCE_DIR WORK_DIR
set -e
sim=$1 replay=$2 source=$3 work=$4
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
"$sim" posts-through "$work/seq" --width 320 --rate 10 --frames 60 >/dev/null
# Every pose turned 180 degrees about the vertical: the camera looks back along the track.
awk 'BEGIN { OFS = " " } /^#/ || NF != 8 { print; next }
  { # q = (0,0,1,0) * (qx,qy,qz,qw): x -> -y, y -> x, z -> w, w -> -z
    print $1, $2, $3, $4, -$6, $5, $8, -$7 }' "$work/seq/groundtruth.txt" >"$work/gt" &&
  mv "$work/gt" "$work/seq/groundtruth.txt"
cat >"$work/prior.csv" <<'CSV'
id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells,last_seen_s
1,obstacle,39.75,-3.75,0,40.25,-3.25,5,0,0
2,obstacle,39.75,3.25,0,40.25,3.75,5,0,0
CSV
"$replay" "$work/seq" --config "$source/config/paper-flight3.yaml" --out "$work/run" --quiet \
  --no-record --prior "$work/prior.csv" --links "$work/run/links" >/dev/null
exec node "$source/tests/js/prior_sectors.mjs" "$work/run/links/obstacles.tlog" "$work/seq" \
  "$work/run/boxes.csv" "$work/run/stats.json"
