#!/bin/sh
# Regenerates the issue-6 acceptance runs (docs/acceptance/issue6.md). Assets go to
# build/accept6 (git-ignored); run from the repository root after building build/release.
set -e
V=build/release/bin/vgeo
mkdir -p build/accept6
for s in sphere terrain torus islands; do
  [ -f build/accept6/$s.vgeo ] || { $V gen $s -n 400000 -s 5 -o build/accept6/$s.ply && $V build build/accept6/$s.ply -o build/accept6/$s.vgeo --threads 2; }
done
for budget in 1536KiB 2560KiB; do
  for disk in fast slow; do
    if [ $disk = fast ]; then lat=0.1; bw=2000; else lat=5; bw=100; fi
    out=build/accept6/run_${budget}_$disk
    mkdir -p $out
    $V render tests/scenes/stream_flythrough.json --stream-budget $budget --frames 120 --threads 2 \
      --disk-latency-ms $lat --disk-bandwidth-mbs $bw --out-dir $out --save-every 15 \
      --json-file $out/metrics.json > $out/table.txt
    grep -A1 "stream summary" $out/table.txt
  done
done
