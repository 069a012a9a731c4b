#!/usr/bin/env bash
# Every thread the program runs is started through os::Task (hal/os/task.*):
# named, at its real-time settings, a refusal reported one way. No other file
# of the program (core, HAL, runtime, daemon, tools) constructs a std::thread
# or std::jthread, calls pthread_create or std::async. Tests may start their own.
#   check_threads.sh SOURCE_DIR
set -uo pipefail
cd "${1:?usage: check_threads.sh SOURCE_DIR}"

# std::thread followed by anything but :: (hardware_concurrency, id) starts or
# holds a thread; so do the others.
pattern='std::(j?thread)([^:]|$)|pthread_create|std::async'
status=0
checked=0
while IFS= read -r file; do
  checked=$((checked + 1))
  case "$file" in hal/os/task.hpp|hal/os/task.cpp) continue ;; esac
  # Comments say what they like.
  if hits="$(sed 's://.*$::' "$file" | grep -nE "$pattern")"; then
    while IFS= read -r hit; do
      echo "$file:${hit%%:*}: a thread started or held outside os::Task: ${hit#*:}"
    done <<<"$hits"
    status=1
  fi
done < <(find include src hal runtime onboard tools -name '*.cpp' -o -name '*.hpp' | sort)
[ "$checked" -gt 0 ] || { echo "no source file found"; exit 1; }
[ $status -eq 0 ] && echo "$checked files: threads start only through os::Task"
exit $status
