#!/bin/bash
# tools/fuzz.sh BUILD_DIR [--runs N] [--jobs J] [--write-results] [TARGET...]:
# every fuzz target (or those named) from its committed seed corpus for
# --runs executions, --jobs at a time, under ASan+UBSan; prints a table of
# executions, rate and coverage of the latest run of every target
# (out/fuzz/<target>.log); --write-results writes it to
# docs/results/fuzzing.md. Findings go to out/fuzz/findings/. ./holofuse
# fuzz builds, then runs this.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${1:?usage: tools/fuzz.sh BUILD_DIR [--runs N] [--jobs J] [--write-results] [TARGET...]}
shift
# Every fuzz target (or those named) from its committed seed corpus for
# --runs executions, --jobs at a time, under ASan+UBSan; prints a table
# of executions, rate and coverage of the latest run of every target
# (out/fuzz/<target>.log); --write-results writes it to
# docs/results/fuzzing.md. Findings go to out/fuzz/findings/.
runs=100000
jobs=$(nproc)
write=0
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=${2:?--runs needs a number}; shift 2 ;;
    --jobs) jobs=${2:?--jobs needs a number}; shift 2 ;;
    --write-results) write=1; shift ;;
    -*) echo "unknown flag '$1'; flags: --runs N --jobs J --write-results [TARGET...]" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[[ "$runs" =~ ^[0-9]+$ && "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "--runs and --jobs take whole numbers" >&2; exit 2; }
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(ls "$root/tests/fuzz/corpus")
for t in "${targets[@]}"; do
  [ -x "$build_dir/fuzz/bin/fuzz_$t" ] || { echo "no fuzz target '$t'; targets: $(ls "$root/tests/fuzz/corpus" | tr '\n' ' ')" >&2; exit 2; }
done
out=$root/out/fuzz
mkdir -p "$out"
echo "[fuzz] ${#targets[@]} targets, $runs executions each, $jobs at a time"
export root build_dir out runs
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c '
  if bash "$root/tests/fuzz/run_fuzzer.sh" "$build_dir/fuzz/bin/fuzz_$1" "$root/tests/fuzz/corpus/$1" \
      "$out/findings" -runs="$runs" -seed=1 -timeout=30 >"$out/$1.log" 2>&1; then r=ok; else r=FAILED; fi
  echo "$r" >>"$out/$1.log"
  echo "[fuzz] $1: $r, $(grep -o "number_of_executed_units: *[0-9]*" "$out/$1.log" | grep -o "[0-9]*$") runs in $(grep -o "^seconds: [0-9]*" "$out/$1.log" | grep -o "[0-9]*$") s"
' _ {}
table=$out/fuzzing.md
{
  printf '<!-- Written by ./holofuse fuzz; do not edit. -->\n# Fuzzing: every target from its seed corpus\n\n'
  printf 'The latest `./holofuse fuzz --runs N [TARGET...]` of each target, on %s, %s cores, clang %s with ASan and UBSan; table of %s.\n\n' \
    "$(. /etc/os-release && echo "$PRETTY_NAME")" "$(nproc)" \
    "$(clang++ --version | head -n 1 | grep -o "[0-9][0-9.]*" | head -n 1)" "$(date -u +%Y-%m-%d)"
  echo "| target | executions | per second | seconds | edges covered | features | inputs added | peak RSS MB | result |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---|"
  for log in "$out"/*.log; do
    t=$(basename "$log" .log)
    [ -d "$root/tests/fuzz/corpus/$t" ] || continue
    stat() { grep -o "$1: *[0-9]*" "$log" | tail -n 1 | grep -o "[0-9]*$"; }
    printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$t" "$(stat number_of_executed_units)" \
      "$(stat average_exec_per_sec)" "$(stat seconds)" "$(stat cov)" "$(stat ft)" \
      "$(stat new_units_added)" "$(stat peak_rss_mb)" "$(tail -n 1 "$log")"
  done
} >"$table"
cat "$table"
if [ "$write" = 1 ]; then
  cp "$table" "$root/docs/results/fuzzing.md"
  echo "[fuzz] wrote docs/results/fuzzing.md"
fi
! grep -q "| FAILED |" "$table"
