#!/usr/bin/env bash
# Where the classic column (a/20, to T = 2.5) is stopped by the guard, over gamma x CFL x the asymmetry surface test.
# Usage: bench/dambreak_stability.sh BUILD_DIR OUT.csv   (one thread per run; ~1 minute in all)
set -euo pipefail
build=$1; out=$2
echo "gamma,cfl,asymmetry,status,steps,time_s,reason" > "$out"
for a in 0 0.9 0.7 0.5; do for c in 0.2 0.1; do for g in 0.01 0.1 0.5 0.99; do
  dir=$(mktemp -d)
  OMP_NUM_THREADS=1 "$build/apps/dambreak/dambreak" --out "$dir" --frames 0 --gamma $g --cfl $c --asymmetry $a \
    > /dev/null 2>&1 || true
  /usr/bin/python3 - "$dir/summary.json" $g $c $a >> "$out" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
reason = s.get("error", "").split("): ")[-1].split(" (reduce")[0].replace(",", ";")
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[4]},{s['status']},{s['steps']},{s['time_s']:.4f},{reason}")
PY
  rm -rf "$dir"
done; done; done
