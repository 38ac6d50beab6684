#!/bin/bash
# The driver's `--view` alone opens the viewer window (demo, rig, replay),
# while `--view orbit|pod:N` still picks the user camera. Fails naming the
# arguments whose translation was wrong.
set -euo pipefail
root=${1:?usage: check_driver_view.sh REPOSITORY_ROOT}
# shellcheck source=/dev/null
source <(sed -n '/^view_args=()/,/^}/p' "$root/holofuse")
failed=0
expect() {
  local want=$1
  shift
  bare_view_opens_window "$@"
  local got="${view_args[*]+${view_args[*]}}"
  if [ "$got" != "$want" ]; then
    echo "holofuse $*: gave the loop '$got', expected '$want'" >&2
    failed=1
  fi
}
expect "--frames 2 --window on" --frames 2 --view
expect "--window on --frames 2" --view --frames 2
expect "--view pod:2 --frames 2" --view pod:2 --frames 2
expect "--view orbit" --view orbit
expect "--mode montage4d" --mode montage4d
expect ""
exit $failed
