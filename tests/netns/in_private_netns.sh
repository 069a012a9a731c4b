#!/bin/sh
# Runs a test program in a private network namespace with only loopback up and
# multicast routed to it, so multicast never leaves the test.
# Root (a chroot, a container, CI's VM) has what it needs: unshare -n. Anyone else
# asks for a user namespace too (unshare -rn). Where the kernel refuses both (an
# unprivileged container), the test is skipped with the reason (exit 77).
#   in_private_netns.sh PROGRAM [ARGS...]
if [ "$(id -u)" -eq 0 ]; then flags=-n; else flags=-rn; fi
if ! why=$(unshare $flags true 2>&1); then
  echo "SKIP: no private network namespace here (unshare $flags: $why)"
  exit 77
fi
exec unshare $flags sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$@"' sh "$@"
