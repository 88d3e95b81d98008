#!/usr/bin/env python3
"""Checks that VTK (the library ParaView reads files with) loads a demcal snapshot series.

    python3 tools/paraview/check_pvd.py OUT_DIR [--scene SCENE.toml] [--run DEMCAL]
                                        [--particles N] [--clumps N]
                                        [--polyhedra N] [--polyhedron-faces N]

OUT_DIR holds what `demcal simulate` wrote: particles.pvd, geometry.pvd, and contacts.pvd,
bonds.pvd and polyhedra.pvd when the run has them. With --run, DEMCAL (the demcal binary) first runs
`simulate SCENE --out OUT_DIR`. With --scene, the times every collection lists must be the
scene's snapshot times ([output] snapshot_interval from 0 to [simulation] duration, and the end),
the contacts must be there when the scene asks for them ([output] contacts = true), and every
geometry with a [[geometry.motion]] must move between the first and the last snapshot.

Each .vtp file is read with vtkXMLPolyDataReader; the .pvd collections are read as XML (the
`vtk` Python package has no reader for them: ParaView's vtkPVDReader is ParaView's own, and is
used here as well when the Python running this script has it).

Prints what it checked and exits 0, or prints every failure and exits 1 (2 for bad arguments,
or when the vtk package is missing: `python3 -m pip install vtk`).
"""

import argparse
import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None

try:
    import vtk
except ImportError:
    print("check_pvd: the vtk package is missing: python3 -m pip install vtk", file=sys.stderr)
    sys.exit(2)

PARTICLE_ARRAYS = {
    "radius": 1,
    "material_id": 1,
    "id": 1,
    "velocity": 3,
    "angular_velocity": 3,
    "clump_id": 1,
    "orientation": 4,
    "clump_axis": 3,
}
CONTACT_ARRAYS = {"normal_force": 1, "force": 3, "tangential_force": 3, "overlap": 1}
BOND_ARRAYS = {"intact": 1, "normal_force": 1, "shear_force": 1}


class Check:
    def __init__(self):
        self.failures = []
        self.notes = []

    def fail(self, message):
        self.failures.append(message)

    def expect(self, condition, message):
        if not condition:
            self.fail(message)
        return condition


def read_collection(path):
    """[(time, part, file)] of a .pvd, in file order."""
    root = ET.parse(path).getroot()
    if root.get("type") != "Collection":
        raise ValueError(f"{path}: not a VTK collection (type={root.get('type')!r})")
    entries = []
    for ds in root.iter("DataSet"):
        entries.append((float(ds.get("timestep")), int(ds.get("part", "0")), ds.get("file")))
    return entries


def read_vtp(check, path):
    if not check.expect(os.path.isfile(path), f"{path}: listed but missing"):
        return None
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    if reader.GetErrorCode() != 0:
        check.fail(f"{path}: VTK could not read it (error code {reader.GetErrorCode()})")
        return None
    data = reader.GetOutput()
    check.expect(data is not None, f"{path}: VTK read no data")
    return data


def step_of(file):
    m = re.search(r"_(\d+)\.vtp$", file)
    return int(m.group(1)) if m else None


def field_value(data, name):
    a = data.GetFieldData().GetArray(name)
    return a.GetValue(0) if a is not None and a.GetNumberOfTuples() > 0 else None


def check_arrays(check, path, attributes, count, wanted, what):
    for name, components in wanted.items():
        a = attributes.GetArray(name)
        if not check.expect(a is not None, f"{path}: no {what} array {name!r}"):
            continue
        check.expect(
            a.GetNumberOfComponents() == components,
            f"{path}: {name} has {a.GetNumberOfComponents()} components, expected {components}",
        )
        check.expect(
            a.GetNumberOfTuples() == count,
            f"{path}: {name} has {a.GetNumberOfTuples()} values, expected {count}",
        )


def expected_times(scene):
    sim, out = scene.get("simulation", {}), scene.get("output", {})
    interval, duration = out.get("snapshot_interval"), sim.get("duration")
    if duration is None:
        return None
    times = []
    if interval:
        k = 0
        while k * interval <= duration * (1 + 1e-12):
            times.append(k * interval)
            k += 1
    else:
        times.append(0.0)
    if not math.isclose(times[-1], duration, rel_tol=1e-9, abs_tol=1e-15):
        times.append(duration)
    return times


def check_times(check, name, entries, expected):
    times = sorted(set(t for t, _, _ in entries))
    check.expect(len(times) > 0, f"{name}: lists no snapshot")
    if not times:
        return times
    # Every file is named by its step: time / step is the time step, the same for all.
    dts = [t / step_of(f) for t, _, f in entries if step_of(f) and t > 0]
    dt = dts[0] if dts else 0.0
    for t, _, f in entries:
        s = step_of(f)
        if s is not None and "static" not in f:
            check.expect(
                math.isclose(t, s * dt, rel_tol=1e-9, abs_tol=1e-15),
                f"{name}: {f} is listed at t = {t!r}, not step {s} x dt {dt!r}",
            )
    check.expect(times[0] == 0.0, f"{name}: the first time is {times[0]!r}, not 0")
    if expected is not None:
        ok = len(times) == len(expected) and all(
            abs(a - b) <= dt + 1e-12 for a, b in zip(times, expected)
        )
        check.expect(
            ok,
            f"{name}: times {['%.6g' % t for t in times]} are not the scene's snapshot times "
            f"{['%.6g' % t for t in expected]} (within one time step {dt:.3g} s)",
        )
    return times


def check_pvd_reader(check, path, times):
    """ParaView's own reader, where this Python has it (pvpython)."""
    cls = getattr(vtk, "vtkPVDReader", None)
    if cls is None:
        try:
            from paraview.modules.vtkPVVTKExtensionsIOCore import vtkPVDReader as cls
        except Exception:
            return False
    reader = cls()
    reader.SetFileName(path)
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    key = vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    steps = [info.Get(key, k) for k in range(info.Length(key))] if info.Has(key) else []
    check.expect(
        len(steps) == len(times) and all(math.isclose(a, b) for a, b in zip(steps, times)),
        f"{path}: vtkPVDReader gives times {steps}, expected {times}",
    )
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the folder demcal simulate wrote")
    parser.add_argument("--scene", help="the scene file, for the expected times and motions")
    parser.add_argument("--run", metavar="DEMCAL", help="run DEMCAL simulate SCENE --out OUT first")
    parser.add_argument("--particles", type=int, help="spheres every particles file must hold")
    parser.add_argument("--clumps", type=int, help="clumps (polyhedra included) every particles file must hold")
    parser.add_argument("--polyhedra", type=int, help="polyhedra every polyhedra file must hold")
    parser.add_argument("--polyhedron-faces", type=int, help="faces of each polyhedron")
    args = parser.parse_args()

    scene = None
    if args.scene:
        if tomllib is None:
            parser.error("--scene needs Python 3.11 or later (tomllib)")
        with open(args.scene, "rb") as f:
            scene = tomllib.load(f)
    if args.run:
        if not args.scene:
            parser.error("--run needs --scene")
        cmd = [args.run, "simulate", args.scene, "--out", args.out]
        print("check_pvd: running", " ".join(cmd), flush=True)
        if subprocess.run(cmd).returncode != 0:
            print(f"check_pvd: FAIL: {' '.join(cmd)} failed", file=sys.stderr)
            return 1

    check = Check()
    out = args.out
    expected = expected_times(scene) if scene else None

    # Particles.
    particles_pvd = os.path.join(out, "particles.pvd")
    if not os.path.isfile(particles_pvd):
        print(f"check_pvd: FAIL: {particles_pvd} is missing", file=sys.stderr)
        return 1
    entries = read_collection(particles_pvd)
    times = check_times(check, "particles.pvd", entries, expected)
    if check_pvd_reader(check, particles_pvd, times):
        check.notes.append("vtkPVDReader read the times")
    counts = set()
    for t, _, f in entries:
        path = os.path.join(out, f)
        data = read_vtp(check, path)
        if data is None:
            continue
        n = data.GetNumberOfPoints()
        counts.add(n)
        check.expect(n > 0, f"{path}: no points")
        if args.particles is not None:
            check.expect(n == args.particles, f"{path}: {n} points, expected {args.particles}")
        check.expect(data.GetNumberOfVerts() == n, f"{path}: {data.GetNumberOfVerts()} vertices for {n} points")
        pd = data.GetPointData()
        check_arrays(check, path, pd, n, PARTICLE_ARRAYS, "point")
        tv = field_value(data, "TimeValue")
        check.expect(tv is not None and math.isclose(tv, t, abs_tol=1e-15), f"{path}: TimeValue {tv} but listed at {t}")
        radius, clump, q = pd.GetArray("radius"), pd.GetArray("clump_id"), pd.GetArray("orientation")
        if radius is not None and n:
            check.expect(radius.GetRange()[0] > 0, f"{path}: a radius is not positive")
        if clump is not None and q is not None:
            ids = {int(clump.GetValue(k)) for k in range(n)}
            ids.discard(-1)
            if args.clumps is not None:
                check.expect(len(ids) == args.clumps, f"{path}: {len(ids)} clumps, expected {args.clumps}")
            bad = [k for k in range(n) if abs(math.hypot(*q.GetTuple4(k)) - 1) > 1e-6]
            check.expect(not bad, f"{path}: {len(bad)} orientations are not unit quaternions")
    check.notes.append(
        f"particles.pvd: {len(entries)} snapshots at t = {', '.join('%.4g' % t for t in times)} s, "
        f"{'/'.join(str(c) for c in sorted(counts))} points each"
    )

    # Geometry.
    geometry_pvd = os.path.join(out, "geometry.pvd")
    scene_geometries = (scene or {}).get("geometry", [])
    if scene_geometries or os.path.isfile(geometry_pvd):
        if check.expect(os.path.isfile(geometry_pvd), f"{geometry_pvd} is missing"):
            check_geometry(check, out, geometry_pvd, times, scene_geometries)

    # Contacts.
    contacts_pvd = os.path.join(out, "contacts.pvd")
    wanted = bool((scene or {}).get("output", {}).get("contacts", False))
    if wanted or os.path.isfile(contacts_pvd):
        if check.expect(os.path.isfile(contacts_pvd), f"{contacts_pvd} is missing (the scene asks for contacts)"):
            check_lines(check, out, contacts_pvd, times, CONTACT_ARRAYS, counts, "contacts", need_lines=True)
    bonds_pvd = os.path.join(out, "bonds.pvd")
    if os.path.isfile(bonds_pvd):
        check_lines(check, out, bonds_pvd, times, BOND_ARRAYS, counts, "bonds", need_lines=False)

    polyhedra_pvd = os.path.join(out, "polyhedra.pvd")
    if args.polyhedra is not None or os.path.isfile(polyhedra_pvd):
        if check.expect(os.path.isfile(polyhedra_pvd), f"{polyhedra_pvd} is missing"):
            check_polyhedra(check, out, polyhedra_pvd, times, args.polyhedra, args.polyhedron_faces)

    for n in check.notes:
        print(f"check_pvd: {n}")
    if check.failures:
        for f in check.failures:
            print(f"check_pvd: FAIL: {f}", file=sys.stderr)
        print(f"check_pvd: {len(check.failures)} failures in {out}", file=sys.stderr)
        return 1
    print(f"check_pvd: OK: VTK {vtk.vtkVersion.GetVTKVersion()} loads the series in {out}")
    return 0


def check_geometry(check, out, pvd, times, scene_geometries):
    entries = read_collection(pvd)
    gtimes = sorted(set(t for t, _, _ in entries))
    check.expect(gtimes == times, f"geometry.pvd: times {gtimes} differ from particles.pvd's {times}")
    names = None
    # Points of each geometry id at the first and the last time.
    first, last = {}, {}
    files = set()
    for t in gtimes:
        seen = set()
        cells = 0
        for _, part, f in (e for e in entries if e[0] == t):
            files.add(f)
            path = os.path.join(out, f)
            data = read_vtp(check, path)
            if data is None:
                continue
            cells += data.GetNumberOfCells()
            gn = data.GetFieldData().GetAbstractArray("geometry_names")
            if check.expect(gn is not None, f"{path}: no geometry_names field data"):
                names = [gn.GetValue(k) for k in range(gn.GetNumberOfValues())]
            gid = data.GetCellData().GetArray("geometry_id")
            if not check.expect(gid is not None, f"{path}: no geometry_id cell data"):
                continue
            check.expect(gid.GetNumberOfTuples() == data.GetNumberOfCells(), f"{path}: geometry_id does not cover every cell")
            for c in range(data.GetNumberOfCells()):
                g = int(gid.GetValue(c))
                seen.add(g)
                ids = data.GetCell(c).GetPointIds()
                pts = [data.GetPoint(ids.GetId(k)) for k in range(ids.GetNumberOfIds())]
                if t == gtimes[0]:
                    first.setdefault(g, []).extend(pts)
                if t == gtimes[-1]:
                    last.setdefault(g, []).extend(pts)
        check.expect(cells > 0, f"geometry.pvd: no cells at t = {t}")
        if scene_geometries:
            check.expect(
                seen == set(range(len(scene_geometries))),
                f"geometry.pvd: at t = {t} the geometries drawn are {sorted(seen)}, expected all {len(scene_geometries)}",
            )
    if names is not None and scene_geometries and all("name" in g for g in scene_geometries):
        want = [g["name"] for g in scene_geometries]
        check.expect(names == want, f"geometry_names {names} differ from the scene's {want}")
    moved = []
    for k, g in enumerate(scene_geometries):
        if not g.get("motion") or len(gtimes) < 2:
            continue
        a, b = first.get(k, []), last.get(k, [])
        if not check.expect(a and b, f"geometry {g.get('name', k)}: not drawn at the first and last time"):
            continue
        ca = [sum(p[i] for p in a) / len(a) for i in range(3)]
        cb = [sum(p[i] for p in b) / len(b) for i in range(3)]
        d = math.dist(ca, cb)
        if check.expect(d > 1e-9, f"geometry {g.get('name', k)} has a motion but did not move between t = {gtimes[0]} and {gtimes[-1]}"):
            moved.append(f"{g.get('name', k)} by {d:.4g} m")
    check.notes.append(
        f"geometry.pvd: {len(files)} files for {len(gtimes)} times"
        + (f"; moved: {', '.join(moved)}" if moved else "")
    )


def check_lines(check, out, pvd, times, arrays, counts, what, need_lines):
    entries = read_collection(pvd)
    ltimes = sorted(set(t for t, _, _ in entries))
    check.expect(ltimes == times, f"{what}.pvd: times {ltimes} differ from particles.pvd's {times}")
    lines = []
    for t, _, f in entries:
        path = os.path.join(out, f)
        data = read_vtp(check, path)
        if data is None:
            continue
        n = data.GetNumberOfPoints()
        check.expect(n in counts, f"{path}: {n} points, the particles files have {sorted(counts)}")
        cells = data.GetNumberOfLines()
        lines.append(cells)
        check.expect(cells == data.GetNumberOfCells(), f"{path}: cells other than lines")
        check_arrays(check, path, data.GetCellData(), cells, arrays, "cell")
    if need_lines:
        check.expect(any(lines), f"{what}.pvd: no snapshot has a single line")
    check.notes.append(f"{what}.pvd: {len(entries)} snapshots, lines per snapshot {lines}")


POLYHEDRON_ARRAYS = {"id": 1, "clump_id": 1, "material_id": 1, "velocity": 3}


def check_polyhedra(check, out, pvd, times, count, faces):
    """Every snapshot's polyhedra: closed polygon surfaces, `faces` polygons per body, each body's
    faces sharing its id, and the bodies moving between the first and the last snapshot."""
    entries = read_collection(pvd)
    ptimes = sorted(set(t for t, _, _ in entries))
    check.expect(ptimes == times, f"polyhedra.pvd: times {ptimes} differ from particles.pvd's {times}")
    centres = []
    for t, _, f in entries:
        path = os.path.join(out, f)
        data = read_vtp(check, path)
        if data is None:
            continue
        polys = data.GetNumberOfPolys()
        check.expect(polys == data.GetNumberOfCells() and polys > 0, f"{path}: {polys} polygons of {data.GetNumberOfCells()} cells")
        check_arrays(check, path, data.GetCellData(), polys, POLYHEDRON_ARRAYS, "cell")
        ids = data.GetCellData().GetArray("id")
        if ids is None:
            continue
        per_body = {}
        for k in range(polys):
            per_body.setdefault(int(ids.GetValue(k)), []).append(k)
        if count is not None:
            check.expect(len(per_body) == count, f"{path}: {len(per_body)} polyhedra, expected {count}")
        if faces is not None:
            bad = [b for b, cells in per_body.items() if len(cells) != faces]
            check.expect(not bad, f"{path}: polyhedra {bad[:5]} do not have {faces} faces")
        # Each face is a closed polygon of at least 3 corners; the mean of a body's points is its
        # centre, which should move under gravity.
        points = data.GetPoints()
        idl = vtk.vtkIdList()
        centre = []
        for b in sorted(per_body):
            pts = set()
            for k in per_body[b]:
                data.GetCellPoints(k, idl)
                check.expect(idl.GetNumberOfIds() >= 3, f"{path}: a face of polyhedron {b} has {idl.GetNumberOfIds()} corners")
                pts.update(idl.GetId(j) for j in range(idl.GetNumberOfIds()))
            xs = [points.GetPoint(p) for p in pts]
            centre.append(tuple(sum(c[i] for c in xs) / len(xs) for i in range(3)))
        centres.append(centre)
    if len(centres) > 1 and centres[0] and len(centres[0]) == len(centres[-1]):
        moved = max(abs(a[2] - b[2]) for a, b in zip(centres[0], centres[-1]))
        check.expect(moved > 1e-4, f"polyhedra.pvd: the polyhedra did not move ({moved:.2e} m)")
        check.notes.append(f"polyhedra.pvd: {len(entries)} snapshots, {len(centres[0])} polyhedra, largest fall {moved:.4f} m")


if __name__ == "__main__":
    sys.exit(main())
