#!/bin/sh
# Regenerates the issue-6 acceptance runs (docs/acceptance/issue6.md): 2 budgets x 2 simulated
# disks x REPS repetitions (default 3), then prints the table (medians, min-max over the
# repetitions). Assets and runs go to build/accept6/p32 (git-ignored); run from the repository
# root after building build/release.
set -e
V=build/release/bin/vgeo
A=build/accept6/p32
REPS=${REPS:-3}
mkdir -p $A
for s in sphere terrain torus islands; do
  [ -f build/accept6/$s.ply ] || $V gen $s -n 400000 -s 5 -o build/accept6/$s.ply
  [ -f $A/$s.vgp ] || $V build build/accept6/$s.ply -o $A/$s.vgp --threads 2 --page-size 32KiB
done
uptime
for rep in $(seq 1 $REPS); do
  for budget in 1536KiB 2048KiB; do
    for disk in fast slow; do
      if [ $disk = fast ]; then lat=0.1; bw=2000; else lat=10; bw=50; fi
      out=$A/run_${budget}_${disk}_$rep
      mkdir -p $out
      $V render tests/scenes/stream_flythrough.json --stream-budget $budget --frames 180 --frame-ms 16.7 --threads 2 \
        --disk-latency-ms $lat --disk-bandwidth-mbs $bw --out-dir $out --save-every 15 \
        --json-file $out/metrics.json > $out/table.txt
      echo "$budget $disk #$rep: $(grep 'stream summary' $out/table.txt)"
    done
  done
done
uptime
python3 - "$A" "$REPS" <<'PY'
import json, statistics, sys
a, reps = sys.argv[1], int(sys.argv[2])
M = 2 ** 20
print("| budget | disk | bytes read / file | read while moving | read after stop | pop-in frames (of 180) "
      "| frames to converge after stop | peak pool | evictions | median ms/frame |")
print("|---|---|---|---|---|---|---|---|---|---|")
for budget in ("1536KiB", "2048KiB"):
    for disk in ("fast", "slow"):
        runs = [json.load(open(f"{a}/run_{budget}_{disk}_{r}/metrics.json"))["stream_summary"] for r in range(1, reps + 1)]
        def col(f, fmt="{:.0f}"):
            v = [f(s) for s in runs]
            m = statistics.median(v)
            lo, hi = fmt.format(min(v)), fmt.format(max(v))
            return fmt.format(m) + (f" ({lo}–{hi})" if lo != hi else "")
        s0 = runs[0]
        print(f"| {s0['budget_bytes'] / M:.1f} MiB | {disk} "
              f"| {col(lambda s: s['bytes_read'] / s['file_bytes'], '{:.3f}')} of {s0['file_bytes'] / M:.2f} MiB "
              f"| {col(lambda s: (s['bytes_read'] - s['bytes_read_after_stop']) / M, '{:.2f}')} MiB, "
              f"{col(lambda s: s['pages_loaded'] - s['pages_loaded_after_stop'])} pages "
              f"| {col(lambda s: s['bytes_read_after_stop'] / M, '{:.2f}')} MiB, {col(lambda s: s['pages_loaded_after_stop'])} pages "
              f"| {col(lambda s: s['popin_frames'])} | {col(lambda s: s['frames_to_converge'])} "
              f"| {col(lambda s: s['peak_reserved_bytes'] / M, '{:.2f}')} MiB | {col(lambda s: s['pages_evicted'])} "
              f"| {col(lambda s: s['median_frame_ms'], '{:.1f}')} |")
s0 = runs[0]
print(f"page data {s0['page_bytes'] / M:.2f} MiB (memory form), stopped view needs {s0['stop_required_bytes'] / M:.2f} MiB, "
      f"stop frame {s0['stop_frame']}")
PY
