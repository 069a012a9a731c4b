#!/usr/bin/env bash
# The layers, as the tree shows them, checked on every project #include:
#   core      include/zonemap/<stage>,    pure computation, one folder a stage in the order
#             src/<stage>                 data flows: common, containers, pose, depth,
#                                         integrator, zones, mapping, features, outputs. A
#                                         stage includes only itself and the stages before
#                                         it; a public header (include/) never an internal
#                                         one (src/)
#   HAL       hal/<edge>                  back-ends behind small interfaces: core + HAL,
#                                         never the runtime or a program
#   runtime   runtime/                    threads and queues: core + HAL interfaces,
#                                         never a back-end or a program
#   onboard   onboard/                    the vehicle program: core, HAL, runtime;
#                                         never a desk tool
#   programs  tools/                      anything
#   core tests tests/core/<stage>          the core's public headers only (they link the
#                                         core alone), and the scene renderer
#   scene     tools/sim/scene*,           the generated scenes' rendering: the core's
#             tools/sim/scenarios*        public headers and itself only (the core's
#                                         tests render with it)
# plus, inside the HAL: an interface or shared folder (frames, ins, output, os, config,
# codec) never includes a back-end (replay, v4l2, can, lcm, mavlink, ins_log, record), and the replay back-end
# (the host HAL) no vehicle link: recorded INS logs reach it through hal/ins's interface.
# Known debts that break a rule are listed below with their reason; one that no
# longer occurs fails too, so the list only shrinks.
#   check_includes.sh SOURCE_DIR
set -uo pipefail
cd "${1:?usage: check_includes.sh SOURCE_DIR}"

# file:included-path pairs that are allowed for now, and why.
known_debts=(
)

stages=(common containers pose depth integrator zones mapping features outputs)
stage_rank() {  # stage name -> its place in the order, or nothing
  local i
  for i in "${!stages[@]}"; do [ "${stages[$i]}" = "$1" ] && echo "$i"; done
}

violations=()
seen_debts=()
check() {  # file included rule
  local pair="$1:$2"
  for d in "${known_debts[@]}"; do
    if [ "$d" = "$pair" ]; then
      seen_debts+=("$d")
      return
    fi
  done
  violations+=("$1 includes $2: $3")
}

while IFS= read -r line; do
  file="${line%%:*}"
  inc="$(sed -n 's/.*#include "\([^"]*\)".*/\1/p' <<<"${line#*:}")"
  [ -n "$inc" ] || continue
  case "$file" in
    include/zonemap/*|src/*)
      # The core's public headers (zonemap/<stage>/...), or its internal ones beside
      # the sources (src/<stage>/...), of the file's own stage or one before it.
      rest="${file#include/zonemap/}"
      rest="${rest#src/}"
      own="${rest%%/*}"
      case "$inc" in
        zonemap/*) target="${inc#zonemap/}" ;;
        *) target="$inc"
           [ -f "src/$inc" ] || { check "$file" "$inc" "the core includes only the core"; continue; }
           case "$file" in include/*) check "$file" "$inc" "a public header never includes an internal one" ;; esac ;;
      esac
      target="${target%%/*}"
      own_rank="$(stage_rank "$own")"
      target_rank="$(stage_rank "$target")"
      if [ -z "$own_rank" ]; then
        check "$file" "$inc" "every core file lies in a stage's folder"
      elif [ -z "$target_rank" ]; then
        check "$file" "$inc" "the core includes only the core's stages"
      elif [ "$target_rank" -gt "$own_rank" ]; then
        check "$file" "$inc" "a stage includes only the stages before it"
      fi ;;
    runtime/*)
      case "$inc" in tools/*|onboard/*) check "$file" "$inc" "the runtime never includes a program" ;; esac
      case "$inc" in hal/replay/*|hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*|hal/record/*)
        check "$file" "$inc" "the runtime sees back-ends only through their interfaces" ;; esac ;;
    hal/frames/*|hal/ins/*|hal/output/*|hal/os/*|hal/config/*|hal/codec/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac
      case "$inc" in hal/replay/*|hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*|hal/record/*)
        check "$file" "$inc" "an interface folder never includes a back-end" ;; esac ;;
    hal/replay/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac
      case "$inc" in hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*|hal/record/*)
        check "$file" "$inc" "the replay back-end needs no vehicle link nor the recorder" ;; esac ;;
    hal/record/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac
      case "$inc" in hal/replay/*|hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*)
        check "$file" "$inc" "the recorder writes what the interfaces carry: no other back-end" ;; esac ;;
    onboard/*)
      case "$inc" in tools/*) check "$file" "$inc" "the onboard program never includes a desk tool" ;; esac ;;
    tests/core/*)
      case "$inc" in zonemap/*|tools/sim/scene.hpp|tools/sim/scenarios.hpp) ;; *) [ -f "tests/core/$inc" ] ||
        check "$file" "$inc" "the core's tests include only the core's public headers, the scene renderer (and their own helpers)" ;; esac ;;
    tools/sim/scene*|tools/sim/scenarios*)
      case "$inc" in zonemap/*|tools/sim/scene.hpp|tools/sim/scenarios.hpp) ;; *)
        check "$file" "$inc" "the scene renderer includes only the core's public headers (the core's tests link it)" ;; esac ;;
    hal/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac ;;
  esac
done < <(grep -rn --include='*.hpp' --include='*.cpp' --include='*.h' '^#include "' include src hal runtime onboard tests/core tools/sim |
         sed 's/:[0-9]*:/:/')

status=0
for v in "${violations[@]}"; do
  echo "layer violation: $v"
  status=1
done
for d in "${known_debts[@]}"; do
  found=0
  for s in "${seen_debts[@]}"; do [ "$s" = "$d" ] && found=1; done
  if [ $found -eq 0 ]; then
    echo "known debt no longer occurs (remove it from the list): $d"
    status=1
  fi
done
[ $status -eq 0 ] && echo "layers: every #include runs one way (${#known_debts[@]} known debts listed)"
exit $status
