#!/bin/bash
# alternate head and new binaries: sweep of N seed cantilevers, 1 s, 2 threads
cd /work/main
for round in 1 2; do
 for N in 1 8 16 24 64; do
  for bin in /tmp/headbuild/bin/manyrods build/bin/manyrods; do
   tag=$([ "$bin" = build/bin/manyrods ] && echo new || echo head)
   s=$(date +%s.%N)
   $bin sweep tools/scenes/seed_cantilever.toml --vary rods.0.material.youngs_modulus=1e6:1e6:$N --duration 1 --threads 2 --frames none -o /tmp/sit/sw_$tag.h5 --no-progress > /dev/null 2>&1 || echo FAIL $tag $N
   e=$(date +%s.%N)
   echo "round $round N $N $tag $(echo "$e - $s" | bc)"
  done
 done
done
