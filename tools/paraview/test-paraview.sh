#!/usr/bin/env bash
# Checks that VTK, ParaView's reader library, loads what `demcal simulate` writes: builds demcal,
# runs tools/paraview/scene.toml once with binary and once with ASCII snapshots, and checks both
# series with check_pvd.py (times, points and arrays, geometry that moves, contacts, polyhedra). Installs
# the `vtk` Python package with pip when it is missing. Prints the sizes of the two formats.
#
#   tools/paraview/test-paraview.sh [OUT_DIR]     (default: a new temporary folder)
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
target=${CARGO_TARGET_DIR:-target}
demcal="$target/debug/demcal"
scene=tools/paraview/scene.toml
out=${1:-$(mktemp -d -t demcal-paraview.XXXXXX)}
mkdir -p "$out"

echo "== building demcal"
cargo build --profile test -p demcal-cli

# A Python with vtk: the one on PATH, or pip's vtk wheel into it, or Debian's python3-vtk9 (for a
# bare CI machine whose python3 has no pip) with the system Python.
python=python3
if ! "$python" -c "import vtk" 2>/dev/null; then
    echo "== installing the vtk Python package"
    "$python" -m pip install --quiet vtk 2>/dev/null ||
        "$python" -m pip install --quiet --break-system-packages vtk 2>/dev/null ||
        { command -v apt-get >/dev/null 2>&1 &&
            { apt-get update -qq && apt-get install -y -qq python3-vtk9; } >/dev/null &&
            python=/usr/bin/python3; } || true
    "$python" -c "import vtk" 2>/dev/null || {
        echo "test-paraview: cannot install vtk (python3 -m pip install vtk, or apt-get install python3-vtk9); no check run" >&2
        exit 1
    }
fi

# The ASCII run: the same scene with format = "ascii", its STL path made absolute so that the
# copy can live in the output folder.
ascii_scene="$out/scene_ascii.toml"
sed -e 's/^format = "binary"/format = "ascii"/' \
    -e "s|^file = \"\.\./\.\./|file = \"$root/|" "$scene" >"$ascii_scene"
grep -q '^format = "ascii"' "$ascii_scene" || {
    echo "test-paraview: $scene no longer says format = \"binary\"; update this script" >&2
    exit 1
}

# 300 spheres, 30 rods of 3 spheres, and 20 polyhedra (one bounding sphere each; wedges of 8
# corners and 6 faces in polyhedra.pvd).
expect=(--particles 410 --clumps 50 --polyhedra 20 --polyhedron-faces 6)
for run in binary ascii; do
    s=$scene
    [ "$run" = ascii ] && s=$ascii_scene
    rm -rf "${out:?}/$run"
    echo "== $run: $demcal simulate $s --out $out/$run"
    "$demcal" simulate "$s" --out "$out/$run" --threads 2
    "$python" tools/paraview/check_pvd.py "$out/$run" --scene "$s" "${expect[@]}"
done

size() { stat -c %s "$1"; }
echo "== sizes, binary vs ascii"
# The last snapshot's files: at t = 0 most values are zeros, which ASCII writes in 3 characters.
last_particles=$(cd "$out/binary" && ls particles_*.vtp | tail -n 1)
last_contacts=$(cd "$out/binary" && ls contacts_*.vtp | tail -n 1)
last_geometry=$(cd "$out/binary" && ls geometry_0*.vtp | tail -n 1)
for f in "$last_particles" "$last_contacts" "$last_geometry" geometry_static_00000000.vtp; do
    b=$(size "$out/binary/$f") a=$(size "$out/ascii/$f")
    awk -v f="$f" -v b="$b" -v a="$a" 'BEGIN { printf "%-30s binary %8d B  ascii %8d B  (ascii/binary %.2f)\n", f, b, a, a / b }'
done
b=$(du -sb "$out/binary" | cut -f1) a=$(du -sb "$out/ascii" | cut -f1)
awk -v b="$b" -v a="$a" 'BEGIN { printf "%-30s binary %8d B  ascii %8d B  (ascii/binary %.2f)\n", "whole series", b, a, a / b }'
echo "test-paraview: OK ($out)"
