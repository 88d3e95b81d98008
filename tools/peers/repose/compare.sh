#!/usr/bin/env bash
# Runs the mono-sphere lifted-cylinder scene in LIGGGHTS (repose.lig) and in demcal
# (spheres_repose_epsd.toml; both with epsd rolling friction) for seeds 1..N (default 3), measures every LIGGGHTS heap
# with `demcal heap-angle` (the same measurement demcal's test uses) and prints both means.
# Needs: apt-get install -y liggghts; a release build of demcal (cargo build --release).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
demcal=${DEMCAL:-$root/target/release/demcal}
seeds=${1:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 "$here/make_cylinder.py" "$work/cylinder.stl"
cp "$here/repose.lig" "$work/"
primes=(15485867 32452867 49979693 67867979 86028157 104395303 122949829 141650963)
lig=()
ours=()
for s in $(seq 1 "$seeds"); do
  (cd "$work" && rm -f final.dump && /usr/bin/time -f "%e" -o time.txt liggghts -var seed "${primes[$((s-1))]}" -in repose.lig > log.txt)
  a=$("$demcal" heap-angle "$work/final.dump" --json | tail -1 | python3 -c 'import json,sys; print(json.load(sys.stdin)["angle_of_repose_deg"])')
  n=$(grep -c . "$work/final.dump" || true)
  echo "seed $s: LIGGGHTS $a deg ($(cat "$work/time.txt") s)"
  lig+=("$a")
  b=$("$demcal" test "$here/spheres_repose_epsd.toml" --seed "$s" --json | tail -1 | python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["angle_of_repose_deg"])')
  echo "seed $s: demcal   $b deg"
  ours+=("$b")
done
python3 - "${lig[*]}" "${ours[*]}" <<'PY'
import statistics as st, sys
lig = [float(x) for x in sys.argv[1].split()]
ours = [float(x) for x in sys.argv[2].split()]
sd = lambda v: st.stdev(v) if len(v) > 1 else 0.0
print(f"LIGGGHTS mean {st.mean(lig):.2f} +/- {sd(lig):.2f} deg; demcal mean {st.mean(ours):.2f} +/- {sd(ours):.2f} deg; difference {st.mean(ours) - st.mean(lig):+.2f} deg")
PY
