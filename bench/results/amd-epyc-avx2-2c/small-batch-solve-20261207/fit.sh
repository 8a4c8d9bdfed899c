#!/bin/bash
cd /tmp/sit
for bin in /tmp/headbuild/bin/manyrods /work/main/build/bin/manyrods; do
  tag=$([ "$bin" = /work/main/build/bin/manyrods ] && echo new || echo head)
  s=$(date +%s.%N)
  $bin calibrate /work/main/tools/scenes/seed_cantilever.toml --data measured.h5 \
    --fit rods.0.material.youngs_modulus=log:3e5:3e6 --fit rods.0.damping.tau_extension=log:0.02:0.1 \
    --tolerance 1e-4 -o fit_$tag.h5 --threads 2 > fit_$tag.log 2>&1; rc=$?
  e=$(date +%s.%N)
  echo "$tag rc=$rc $(echo "$e - $s" | bc) s"; tail -3 fit_$tag.log
done
