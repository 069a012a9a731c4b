#!/usr/bin/env bash
# The layers, as the tree shows them, checked on every project #include:
#   core      include/zonemap, src        pure computation: includes only the core
#   HAL       hal/<edge>                  back-ends behind small interfaces: core + HAL,
#                                         never the runtime or a program
#   runtime   runtime/                    threads and queues: core + HAL interfaces,
#                                         never a back-end or a program
#   onboard   onboard/                    the vehicle program: core, HAL, runtime;
#                                         never a desk tool
#   programs  tools/                      anything
# plus, inside the HAL: an interface or shared folder (frames, ins, output, os, config,
# codec) never includes a back-end (replay, v4l2, can, lcm, mavlink, ins_log), and the replay back-end
# (the host HAL) no vehicle link: recorded INS logs reach it through hal/ins's interface.
# Known debts that break a rule are listed below with their reason; one that no
# longer occurs fails too, so the list only shrinks.
#   check_includes.sh SOURCE_DIR
set -uo pipefail
cd "${1:?usage: check_includes.sh SOURCE_DIR}"

# file:included-path pairs that are allowed for now, and why.
known_debts=(
)

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
      # The core's public headers, or its internal ones beside the sources in src/.
      case "$inc" in zonemap/*) ;; *) [ -f "src/$inc" ] || check "$file" "$inc" "the core includes only the core" ;; esac ;;
    runtime/*)
      case "$inc" in tools/*|onboard/*) check "$file" "$inc" "the runtime never includes a program" ;; esac
      case "$inc" in hal/replay/*|hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*)
        check "$file" "$inc" "the runtime sees back-ends only through their interfaces" ;; esac ;;
    hal/frames/*|hal/ins/*|hal/output/*|hal/os/*|hal/config/*|hal/codec/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac
      case "$inc" in hal/replay/*|hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*)
        check "$file" "$inc" "an interface folder never includes a back-end" ;; esac ;;
    hal/replay/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac
      case "$inc" in hal/v4l2/*|hal/can/*|hal/lcm/*|hal/mavlink/*|hal/ins_log/*)
        check "$file" "$inc" "the replay back-end needs no vehicle link" ;; esac ;;
    onboard/*)
      case "$inc" in tools/*) check "$file" "$inc" "the onboard program never includes a desk tool" ;; esac ;;
    hal/*)
      case "$inc" in tools/*|onboard/*|runtime/*) check "$file" "$inc" "the HAL never includes the runtime or a program" ;; esac ;;
  esac
done < <(grep -rn --include='*.hpp' --include='*.cpp' --include='*.h' '^#include "' include src hal runtime onboard |
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
