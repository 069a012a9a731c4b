#!/bin/sh
# report.html rendered by Debian's headless Chromium (report_check.mjs), for the
# posts-around flight mapped single-threaded and with --pipeline (whose report
# also has the end-to-end latency histogram).
# Exit 77 (skipped, with the reason) without Chromium, Node.js or pngjs, or when
# this build has no 3-D view (npm was unreachable when it was built).
#   run_report_check.sh SIM REPLAY SOURCE_DIR WORK_DIR
set -e
sim=$1 replay=$2 source=$3 work=$4
chromium=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chromium" ]; then
  echo "SKIP: Chromium is not installed (tools/test installs Debian's chromium)"
  exit 77
fi
. "$(dirname "$0")/need_node.sh"
rm -rf "$work"
"$sim" posts-around "$work/seq" --width 640 --rate 10 --frames 120 >/dev/null
for mode in single pipeline; do
  flag=""
  [ "$mode" = pipeline ] && flag=--pipeline
  "$replay" "$work/seq" --config "$source/config/paper-flight1.yaml" --out "$work/$mode" \
    --quiet --no-record $flag >/dev/null
  if grep -q "No 3-D view in this build" "$work/$mode/report.html"; then
    echo "SKIP: this build has no 3-D view (npm was unreachable when it was built)"
    exit 77
  fi
  echo "$mode:"
  node "$source/tests/js/report_check.mjs" "$chromium" "$work/$mode" || exit $?
done
