#!/usr/bin/env bash
# The house's include rules (docs/architecture.md "Libraries and folders"),
# read from the sources: an arrow that runs the wrong way fails here, by
# name, before it becomes a build that only works from this tree.
#   include/manyrods/  includes only <...> and "manyrods/..." (the public API)
#   host/core/         never host/scene/, host/capi/ or a scene folder
#   host/scene/        only the public headers and its own folders
#                      ("setup/", "io/", "run/", "study/"): no kernels/, no host/
#   host/capi/, tools/manyrods.cpp, tools/plot.*, python/src/: the public
#                      headers only (and their own folder's: bindings.h, plot.h)
# Usage: check-includes.sh SOURCE_DIR
set -euo pipefail
cd "$1"
fail=0
check() {  # check FILES... -- ALLOWED_REGEX
  local allowed=${!#} f
  for f in "${@:1:$#-1}"; do
    while IFS= read -r line; do
      if ! [[ $line =~ $allowed ]]; then
        echo "FAIL: $f: $line"
        fail=1
      fi
    done < <(grep -h '^#include "' "$f" || true)
  done
}
check include/manyrods/*.h '^#include "manyrods/[a-z_0-9]+\.h"'
check $(find host/core -name '*.h' -o -name '*.cpp') '^#include "(manyrods/|kernels/|host/core/|isa_paths\.h")'
check $(find host/scene -name '*.h' -o -name '*.cpp') '^#include "(manyrods/|setup/|io/|run/|study/)'
check host/capi/*.cpp python/src/*.cpp python/src/*.h '^#include "(manyrods/|bindings\.h")'
check tools/manyrods.cpp tools/plot.cpp tools/plot.h '^#include "(manyrods/|plot\.h")'
if [ "$fail" -eq 0 ]; then echo "include rules OK"; fi
exit "$fail"
