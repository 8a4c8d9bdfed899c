#!/usr/bin/env bash
# The C API's shared library exports what include/manyrods/manyrods_c.h
# declares and nothing else (hidden visibility, the static libraries inside it
# excluded), under the SONAME libmanyrods_c.so.<MR_ABI_VERSION>.
#   tests/check-c-exports.sh path/to/libmanyrods_c.so
set -euo pipefail
lib=$1
header=$(dirname "$0")/../include/manyrods/manyrods_c.h
abi=$(sed -n 's/^#define MR_ABI_VERSION \([0-9]*\)$/\1/p' "$header")
soname=$(readelf -d "$lib" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[ "$soname" = "libmanyrods_c.so.$abi" ] || { echo "SONAME is '$soname', expected libmanyrods_c.so.$abi"; exit 1; }
# defined dynamic symbols, less the linker's own markers
exported=$(nm -D --defined-only "$lib" | awk '{print $3}' | grep -vxE '_init|_fini|_edata|_end|__bss_start' | sort)
declared=$(grep -oE '\bmr_[a-z0-9_]+\(' "$header" | tr -d '(' | sort -u)
extra=$(comm -23 <(echo "$exported") <(echo "$declared"))
missing=$(comm -13 <(echo "$exported") <(echo "$declared"))
[ -z "$extra" ] || { echo "exported but not in manyrods_c.h:"; echo "$extra" | head -20; exit 1; }
[ -z "$missing" ] || { echo "declared in manyrods_c.h but not exported:"; echo "$missing"; exit 1; }
echo "$lib: SONAME $soname, $(echo "$exported" | wc -l) mr_* functions exported, nothing else"
