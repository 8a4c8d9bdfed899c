#!/usr/bin/env bash
# A sweep's chunks shared among MPI ranks give the summary and statistics of
# the sweep in one process, bit for bit, for 1, 2 and 4 ranks (more ranks
# than cores: --oversubscribe), and a sharded sweep continues where it
# stopped (a removed chunk is run again, the others are read back).
#   tests/check-mpi-sweep.sh MPIEXEC path/to/manyrods WORKDIR
set -euo pipefail
mpiexec=$1 tool=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
scene=$work/cantilever.toml  # the seed cantilever, coarse, pulled 2 % of L aside
cat > "$scene" <<'TOML'
[simulation]
dt = "auto"
duration = 0.5
output_interval = 0.05
[[rods]]
name = "beam"
elements = 8
length = 0.3
initial_tip_force = [0.0005, 0.0, 0.0]
section = { shape = "rectangle", width = 0.01, height = 0.01 }
material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }
damping = { tau_shear = 0.02, tau_extension = 0.02 }
TOML
vary=(--vary rods.0.material.youngs_modulus=lognormal:1e6:0.2 --vary rods.0.damping.tau_extension=uniform:0.04:0.1
      --design lhs --samples 10 --seed 4 --threads 1)
"$tool" sweep "$scene" "${vary[@]}" -o "$work/one.h5" 2> "$work/one.log"
for np in 1 2 4; do
  "$mpiexec" --oversubscribe -np $np "$tool" sweep "$scene" "${vary[@]}" --chunk 3 -o "$work/np$np.h5" \
    2> "$work/np$np.log"
  grep -q "4 chunks" "$work/np$np.log" || { cat "$work/np$np.log"; exit 1; }
  [ $np = 1 ] || grep -q "($np MPI ranks)" "$work/np$np.log" || { echo "np = $np: not sharded"; cat "$work/np$np.log"; exit 1; }
  cmp "$work/one.csv" "$work/np$np.csv" || { echo "np = $np: the summary differs from the sweep in one batch"; exit 1; }
  cmp "$work/one_statistics.csv" "$work/np${np}_statistics.csv" || { echo "np = $np: the statistics differ"; exit 1; }
  echo "np = $np: summary and statistics identical to the sweep in one batch"
done
rm "$work/np2.h5.chunks/chunk-00002.h5"
"$mpiexec" --oversubscribe -np 2 "$tool" sweep "$scene" "${vary[@]}" --chunk 3 -o "$work/np2.h5" 2> "$work/again.log"
grep -q "3 read back" "$work/again.log" || { cat "$work/again.log"; exit 1; }
cmp "$work/one.csv" "$work/np2.csv"
echo "continued: one chunk run again, three read back, the same summary"
# without --chunk, ranks would write one file together: refused
if "$mpiexec" --oversubscribe -np 2 "$tool" sweep "$scene" "${vary[@]}" -o "$work/bad.h5" 2> "$work/bad.log"; then
  echo "a sweep without --chunk under mpirun was not refused"; exit 1
fi
grep -q "give --chunk" "$work/bad.log"
echo "without --chunk: refused"
