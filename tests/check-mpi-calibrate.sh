#!/usr/bin/env bash
# A calibration whose generations are shared among MPI ranks (each rank one
# batch of its share of the candidates, their tracks gathered) gives the
# calibration in one process, bit for bit (its CSV's 17 digits and its
# printed lines), for 2 and 3 ranks (more ranks than cores: --oversubscribe;
# 3 does not divide the population of 8).
#   tests/check-mpi-calibrate.sh MPIEXEC path/to/manyrods WORKDIR
set -euo pipefail
mpiexec=$1 tool=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
cat > "$work/truth.toml" <<'TOML'
[simulation]
dt = 2e-4
duration = 0.4
output_interval = 0.02
[[rods]]
name = "beam"
elements = 6
length = 0.3
initial_tip_force = [0.005, 0.0, 0.0]
section = { shape = "rectangle", width = 0.01, height = 0.01 }
material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }
damping = { tau_shear = 0.005, tau_extension = 0.02 }
TOML
sed 's/youngs_modulus = 1.0e6/youngs_modulus = 3.0e5/' "$work/truth.toml" > "$work/guess.toml"
"$tool" run "$work/truth.toml" -o "$work/measured.h5" --no-progress 2> /dev/null
fit=(--fit rods.0.material.youngs_modulus=log:1e5:1e7 --fit rods.0.damping.tau_extension=log:0.006:0.2
     --tolerance 1e-4 --seed 3 --threads 1 --no-progress)
"$tool" calibrate "$work/guess.toml" --data "$work/measured.h5" "${fit[@]}" -o "$work/one.h5" \
  > "$work/one.txt" 2> "$work/one.log"
for np in 2 3; do
  "$mpiexec" --oversubscribe -np $np "$tool" calibrate "$work/guess.toml" --data "$work/measured.h5" "${fit[@]}" \
    -o "$work/np$np.h5" > "$work/np$np.txt" 2> "$work/np$np.log"
  grep -q "($np MPI ranks)" "$work/np$np.log" || { echo "np = $np: not sharded"; cat "$work/np$np.log"; exit 1; }
  cmp "$work/one.csv" "$work/np$np.csv" || { echo "np = $np: the fit differs from the one in one process"; exit 1; }
  cmp "$work/one.txt" "$work/np$np.txt" || { echo "np = $np: the printed lines differ"; exit 1; }
  echo "np = $np: the same calibration as in one process: $(head -1 "$work/np$np.txt")"
done
