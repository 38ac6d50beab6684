#!/bin/bash
# Every C++ source of the repository as .clang-format lays it out. Fails
# with the files that are not and the command that fixes them.
set -euo pipefail
root=${1:?usage: check_format.sh REPOSITORY_ROOT}
cd "$root"
format=$(command -v clang-format || true)
if [ -z "$format" ]; then
  echo "clang-format is not installed (Debian package clang-format; ./holofuse deps installs it)" >&2
  exit 1
fi
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files -- '*.cpp' '*.h')
else
  mapfile -t files < <(find . -path ./build -prune -o \( -name '*.cpp' -o -name '*.h' \) -print | sort)
fi
existing=()
for f in "${files[@]}"; do [ -f "$f" ] && existing+=("$f"); done
files=("${existing[@]}")
# One run over every file; only when it finds something, one run per file
# to name them.
off=()
if ! "$format" --style=file --dry-run --Werror "${files[@]}" >/dev/null 2>&1; then
  for f in "${files[@]}"; do
    "$format" --style=file --dry-run --Werror "$f" >/dev/null 2>&1 || off+=("$f")
  done
fi
if [ ${#off[@]} -ne 0 ]; then
  echo "${#off[@]} of ${#files[@]} files are not laid out as .clang-format says:" >&2
  printf '  %s\n' "${off[@]}" >&2
  echo "fix: clang-format -i ${off[*]}" >&2
  exit 1
fi
echo "${#files[@]} files laid out as .clang-format says"
