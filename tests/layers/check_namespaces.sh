#!/usr/bin/env bash
# Namespaces follow the tree: every namespace a file opens (other than one that
# only forward-declares a type) is its folder's.
#   include/zonemap, src      zonemap (and zonemap::simd, src/simd_u16.hpp)
#   hal/<interface folder>    zonemap::hal     (frames, ins, output, config, codec)
#   hal/os                    zonemap::os
#   hal/<back-end>            zonemap::<back-end>  (replay, v4l2, can, mavlink, ins_log,
#                                                   record; lcm: zonemap::lcm_link, as
#                                                   `lcm` is LCM's own C++ namespace)
#   runtime/, onboard/        zonemap::runtime, zonemap::onboard
#   check_namespaces.sh SOURCE_DIR
set -uo pipefail
cd "${1:?usage: check_namespaces.sh SOURCE_DIR}"

expected() {  # file -> namespace
  case "$1" in
    include/zonemap/*|src/*) echo zonemap ;;
    hal/frames/*|hal/ins/*|hal/output/*|hal/config/*|hal/codec/*) echo zonemap::hal ;;
    hal/lcm/*) echo zonemap::lcm_link ;;
    hal/*) local rest="${1#hal/}"; echo "zonemap::${rest%%/*}" ;;
    runtime/*) echo zonemap::runtime ;;
    onboard/*) echo zonemap::onboard ;;
  esac
}

status=0
checked=0
while IFS= read -r file; do
  want="$(expected "$file")"
  [ -n "$want" ] || continue
  checked=$((checked + 1))
  # Named namespaces opened, skipping those whose body is one forward declaration.
  while IFS= read -r got; do
    # A back-end or the runtime may nest its own; the core's one nested namespace
    # (its SIMD lanes) is named here so a layer's namespace cannot hide in it.
    case "$got" in "$want" | zonemap::simd) continue ;; esac
    if [ "$want" = zonemap ] || [ "${got#"$want"::}" = "$got" ]; then
      echo "namespace outside its folder: $file opens $got (its folder's is $want)"
      status=1
    fi
  done < <(awk '
    /^namespace [A-Za-z_:]+ \{/ { name = $2; getline next_line;
      if (next_line !~ /^(class|struct) [A-Za-z_0-9]+;$/) print name }' "$file")
done < <(find include/zonemap src hal runtime onboard -name '*.hpp' -o -name '*.cpp' | sort)

[ $status -eq 0 ] && echo "namespaces: $checked files, each in its folder's namespace"
exit $status
