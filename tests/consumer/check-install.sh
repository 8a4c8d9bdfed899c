#!/usr/bin/env bash
# Installs the build tree into a fresh prefix, builds tests/consumer against
# it as a user's project would, checks what reached the consumer's compile
# commands, and runs it on a scene; then builds and runs the C example
# (examples/c, the C API's shared library) against it the same way.
# Usage: check-install.sh BUILD_DIR CONSUMER_SOURCE WORK_DIR SCENE_FILE [C_EXAMPLE_DIR]
set -euo pipefail
build=$1 src=$2 work=$3 scene=$4 c_example=${5:-}
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
gen=()
if command -v ninja >/dev/null 2>&1; then gen=(-G Ninja); fi
# The README's first ```cpp block, as a function template over the batch's
# precision (RodBatch<double> and build_batch<double> become T; its dt stays
# a double, as a user writes it), called for float and double.
readme="$src/../../README.md"
example="$work/readme_example.cpp"
awk '/^```cpp/ { if (!done) { on = 1; next } } /^```/ { if (on) { on = 0; done = 1 } } on' "$readme" >"$work/readme_block.txt"
[ -s "$work/readme_block.txt" ] || { echo "FAIL: no \`\`\`cpp block in $readme"; exit 1; }
{
  grep -E '^#include' "$work/readme_block.txt"
  echo '#include <cmath>'
  echo '#include <cstdio>'
  grep -E '^using ' "$work/readme_block.txt"
  echo 'template <class T> bool readme_example() {'
  grep -vE '^(#include|using )' "$work/readme_block.txt" | sed -e 's/<double>/<T>/g'
  echo '  std::printf("README example (%s): tip (%g, %g, %g)\n", sizeof(T) == 4 ? "float" : "double", tip[0], tip[1], tip[2]);'
  echo '  return std::isfinite(tip[0]) && std::isfinite(tip[1]) && std::isfinite(tip[2]);'
  echo '}'
  echo 'int main() { return readme_example<float>() && readme_example<double>() ? 0 : 1; }'
} >"$example"
cmake -S "$src" -B "$work/build" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DREADME_EXAMPLE="$example" -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >"$work/configure.log"
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
echo '#include "manyrods/manyrods_c.h"' | gcc -std=c11 -pedantic -Werror -fsyntax-only -I"$work/prefix/include" -x c - \
  || { echo "FAIL: manyrods_c.h is not C11"; fail=1; }
"$work/build/consumer" "$scene" || { echo "FAIL: the consumer did not run"; fail=1; }
"$work/build/readme_example" || { echo "FAIL: the README's example did not run (float and double; $example)"; fail=1; }
[ -f "$work/build/librodplugin.so" ] || { echo "FAIL: no shared plug-in"; fail=1; }
if [ -n "$c_example" ]; then
  cmake -S "$c_example" -B "$work/build-c" "${gen[@]}" -DCMAKE_PREFIX_PATH="$work/prefix" \
    -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >"$work/configure-c.log"
  cmake --build "$work/build-c" >"$work/build-c.log" || { cat "$work/build-c.log"; exit 1; }
  if grep -qE -- "-march=native|-fopenmp" "$work/build-c/compile_commands.json"; then
    echo "FAIL: build flags reached the C example's compile commands"; fail=1
  fi
  "$work/build-c/host_loop" "$c_example/head.toml" 8 || { echo "FAIL: the C example did not run"; fail=1; }
  readelf -d "$work/build-c/host_loop" | grep -q 'NEEDED.*libmanyrods_c.so.0' \
    || { echo "FAIL: the C example does not link libmanyrods_c.so.0"; fail=1; }
fi
if [ "$fail" -eq 0 ]; then echo "install tree OK: consumer built and ran, no build flags leaked"; fi
exit "$fail"
