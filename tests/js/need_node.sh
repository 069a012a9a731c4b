# Sourced by the run_*.sh checks: without Node.js the check is skipped with the
# reason (exit 77), never passed.
if ! command -v node >/dev/null 2>&1; then
  echo "SKIP: Node.js is not installed (tools/test installs it from Debian)"
  exit 77
fi
