#!/bin/sh
# Regenerates the issue-6 acceptance runs (docs/acceptance/issue6.md). Assets go to
# build/accept6/p32 (git-ignored); run from the repository root after building build/release.
set -e
V=build/release/bin/vgeo
A=build/accept6/p32
mkdir -p $A
for s in sphere terrain torus islands; do
  [ -f build/accept6/$s.ply ] || $V gen $s -n 400000 -s 5 -o build/accept6/$s.ply
  [ -f $A/$s.vgeo ] || $V build build/accept6/$s.ply -o $A/$s.vgeo --threads 2 --page-size 32KiB
done
uptime
for budget in 1536KiB 2560KiB; do
  for disk in fast slow; do
    if [ $disk = fast ]; then lat=0.1; bw=2000; else lat=10; bw=50; fi
    out=$A/run_${budget}_$disk
    mkdir -p $out
    $V render tests/scenes/stream_flythrough.json --stream-budget $budget --frames 180 --frame-ms 16.7 --threads 2 \
      --disk-latency-ms $lat --disk-bandwidth-mbs $bw --out-dir $out --save-every 15 \
      --json-file $out/metrics.json > $out/table.txt
    echo "$budget $disk"; grep "stream summary" $out/table.txt
  done
done
uptime
