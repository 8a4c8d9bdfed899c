#!/usr/bin/env bash
# Every example scene is documented: each tools/scenes/*.toml has a row in
# the scene table of docs/scenes.md (what it shows, its time, its exit
# status) and in the README's table of wall times and exit statuses. A
# scene added without its rows fails here, by name.
# Usage: check-scenes-listed.sh SOURCE_DIR
set -euo pipefail
cd "$1"
fail=0
shopt -s nullglob
scenes=(tools/scenes/*.toml)
if [ "${#scenes[@]}" -eq 0 ]; then
  echo "FAIL: no scenes found in tools/scenes/"
  exit 1
fi
for f in "${scenes[@]}"; do
  name=$(basename "$f")
  for doc in docs/scenes.md README.md; do
    # a table row whose first cell is the file name: | `name.toml` | ...
    if ! grep -qF "| \`$name\` |" "$doc"; then
      echo "FAIL: $f is not in the scene table of $doc (a row starting | \`$name\` |)"
      fail=1
    fi
  done
done
if [ "$fail" -eq 0 ]; then echo "scene tables OK (${#scenes[@]} scenes)"; fi
exit "$fail"
