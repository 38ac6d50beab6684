#!/bin/bash
# One libFuzzer run of a fuzz target from its committed seed corpus, which
# it never writes to: new inputs go to a scratch folder that is removed,
# and a crashing input is kept in FINDINGS with the command that replays
# it.
#   run_fuzzer.sh FUZZER CORPUS FINDINGS [libFuzzer flags]
set -uo pipefail
fuzzer=${1:?usage: run_fuzzer.sh FUZZER CORPUS FINDINGS [libFuzzer flags]}
corpus=${2:?}
findings=${3:?}
shift 3
if [ ! -x "$fuzzer" ]; then
  echo "$fuzzer is not built: ./holofuse build makes it with clang (Debian packages clang and libclang-rt-14-dev)" >&2
  exit 1
fi
name=$(basename "$fuzzer")
# The capture readers' scratch folders: in memory where the machine has it.
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
mkdir -p "$findings"
start=$(date +%s)
"$fuzzer" -artifact_prefix="$findings/$name-" -print_final_stats=1 "$@" "$scratch" "$corpus" \
  >"$scratch.log" 2>&1
status=$?
echo "seconds: $(($(date +%s) - start))"
# What a person reads: the executions, their rate, and the coverage reached.
grep -E "^stat::(number_of_executed_units|average_exec_per_sec|new_units_added|peak_rss_mb)|Done [0-9]+ runs" "$scratch.log"
# The coverage it ended with: libFuzzer's last status line (cov: edges, ft: features).
grep -E "^#[0-9]+.*cov: " "$scratch.log" | tail -n 1
if [ $status -ne 0 ]; then
  tail -n 60 "$scratch.log" >&2
  echo "$name failed (exit $status); replay the input it saved: $fuzzer $findings/$name-<crash|leak|timeout>-*" >&2
fi
rm -f "$scratch.log"
exit $status
