#!/usr/bin/env bash
# Installs the build tree into a fresh prefix, builds tests/consumer against
# it as a user's project would, checks what reached the consumer's compile
# commands, and runs it on a scene.
# Usage: check-install.sh BUILD_DIR CONSUMER_SOURCE WORK_DIR SCENE_FILE
set -euo pipefail
build=$1 src=$2 work=$3 scene=$4
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
gen=()
if command -v ninja >/dev/null 2>&1; then gen=(-G Ninja); fi
cmake -S "$src" -B "$work/build" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >"$work/configure.log"
cmake --build "$work/build" >"$work/build.log" || { cat "$work/build.log"; exit 1; }
fail=0
commands="$work/build/compile_commands.json"
for flag in -march=native -fopenmp -fno-math-errno EIGEN_DONT_VECTORIZE eigen3 "$work/prefix/include/manyrods"; do
  if grep -q -- "$flag" "$commands"; then
    echo "FAIL: '$flag' reached the consumer's compile commands:"; grep -- "$flag" "$commands" | head -2
    fail=1
  fi
done
if grep -rlE "#include [<\"](Eigen|host/|kernels/)" "$work/prefix/include/manyrods"; then
  echo "FAIL: installed headers include Eigen, host/ or kernels/ (files above)"
  fail=1
fi
for h in "$work"/prefix/include/manyrods/*.h; do  # every public header compiles on its own
  echo "#include \"manyrods/$(basename "$h")\"" | g++ -std=c++20 -fsyntax-only -I"$work/prefix/include" -x c++ - \
    || { echo "FAIL: $(basename "$h") does not compile on its own"; fail=1; }
done
"$work/build/consumer" "$scene" || { echo "FAIL: the consumer did not run"; fail=1; }
[ -f "$work/build/librodplugin.so" ] || { echo "FAIL: no shared plug-in"; fail=1; }
if [ "$fail" -eq 0 ]; then echo "install tree OK: consumer built and ran, no build flags leaked"; fi
exit "$fail"
