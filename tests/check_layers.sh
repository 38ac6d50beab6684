#!/bin/bash
# The modules' layers point one way: a module includes only itself and
# the modules below it (CONTRIBUTING.md, "Layers"). Fails with every
# include that points up or sideways, by file and line.
set -euo pipefail
root=${1:?usage: check_layers.sh REPOSITORY_ROOT}
cd "$root"
# Bottom first; modules on one line are side by side and may not include
# each other.
layers=(
  "base"
  "protocol"
  "geometry image config gpu"
  "codec texture segmentation metrics"
  "scene hull report"
  "dataset"
  "capture_node fusion_server render_client"
  "eval"
  "deploy"
)
declare -A rank
for i in "${!layers[@]}"; do
  for module in ${layers[$i]}; do rank[$module]=$i; done
done
bad=0
checked=0
for module in "${!rank[@]}"; do
  [ -d "$module" ] || { echo "layer table names $module, which is not a folder" >&2; bad=1; continue; }
  while IFS= read -r hit; do
    file=${hit%%:*}
    rest=${hit#*:}
    line=${rest%%:*}
    target=$(sed -E 's/.*#include "([a-z_]+)\/.*/\1/' <<<"$rest")
    checked=$((checked + 1))
    [ "$target" = "$module" ] && continue
    [ -z "${rank[$target]+x}" ] && continue  # not a module (generated shaders/, a system header)
    if [ "${rank[$target]}" -ge "${rank[$module]}" ]; then
      echo "$file:$line: $module (layer ${rank[$module]}) includes $target (layer ${rank[$target]})" >&2
      bad=1
    fi
  done < <(grep -rnE '^#include "[a-z_]+/' "$module" --include='*.cpp' --include='*.h' || true)
done
if [ "$bad" -ne 0 ]; then
  echo "includes that point up or sideways (layers, bottom first: ${layers[*]})" >&2
  exit 1
fi
echo "$checked includes across ${#rank[@]} modules point down or stay home"
