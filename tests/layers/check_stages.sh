#!/usr/bin/env bash
# The core's stages, in order, are named in four places that must agree: the
# folders (include/zonemap/<stage>, src/<stage>), the build (CMakeLists.txt's
# ZONEMAP_STAGES), the include check (check_includes.sh's stages) and the
# architecture page (its "common ← containers ← ..." chain).
#   check_stages.sh SOURCE_DIR
set -uo pipefail
cd "${1:?usage: check_stages.sh SOURCE_DIR}"

build="$(sed -n 's/^set(ZONEMAP_STAGES \(.*\))$/\1/p' CMakeLists.txt)"
check="$(sed -n 's/^stages=(\(.*\))$/\1/p' tests/layers/check_includes.sh)"
# The chain: from "common ←" to the last stage before ", and a public header".
docs="$(tr '\n' ' ' <docs/architecture.md | grep -o 'common ←[^,]*,' | head -1 |
        sed 's/[←,]/ /g' | tr -s ' ' | sed 's/^ //; s/ $//')"
headers="$(cd include/zonemap && ls -d */ | tr -d '/' | sort | tr '\n' ' ' | sed 's/ $//')"
sources="$(cd src && ls -d */ | tr -d '/' | sort | tr '\n' ' ' | sed 's/ $//')"
sorted_build="$(tr ' ' '\n' <<<"$build" | sort | tr '\n' ' ' | sed 's/ $//')"

status=0
[ -n "$build" ] || { echo "CMakeLists.txt names no ZONEMAP_STAGES"; status=1; }
[ "$check" = "$build" ] || { echo "check_includes.sh's stages ($check) are not the build's ($build)"; status=1; }
[ "$docs" = "$build" ] || { echo "architecture.md's chain ($docs) is not the build's ($build)"; status=1; }
[ "$headers" = "$sorted_build" ] || { echo "include/zonemap holds $headers, the build names $sorted_build"; status=1; }
[ "$sources" = "$sorted_build" ] || { echo "src holds $sources, the build names $sorted_build"; status=1; }
[ $status -eq 0 ] && echo "stages: $build (folders, build, include check and architecture.md agree)"
exit $status
