#!/bin/bash
# every example scene, head and new binaries alternated, 2 threads
cd /work/main
for sc in tools/scenes/*.toml; do
  n=$(basename $sc .toml)
  for bin in /tmp/headbuild/bin/manyrods build/bin/manyrods; do
    tag=$([ "$bin" = build/bin/manyrods ] && echo new || echo head)
    s=$(date +%s.%N)
    $bin run $sc -o /tmp/sit/sc_$tag.h5 --threads 2 --no-progress > /tmp/sit/sc_${n}_$tag.log 2>&1; rc=$?
    e=$(date +%s.%N)
    echo "$n $tag rc=$rc $(echo "$e - $s" | bc)"
  done
done
