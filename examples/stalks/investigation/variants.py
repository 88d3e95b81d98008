#!/usr/bin/env python3
"""Runs one stalk example under the variants the investigation of examples/stalks/README.md tests
(each a change of the example file: the bond radius, the contact stiffness, the specimen, the
fixture, the step, the density scaling) and prints a table of what each gives.

    python3 examples/stalks/investigation/variants.py DEMCAL EXAMPLE OUT [VARIANT ...] [--jobs N]
        [--threads T] [--scaling F] [--set LINE] [--timeout S]

EXAMPLE is shear (stalk_shear.toml), compression (stalk_compression.toml) or safflower
(safflower_neck_shear.toml); with no VARIANT every variant of that example runs. Each run writes
OUT/<example>-<variant>/ (the test's output: curve, side views, result.json) and the table is
printed and written to OUT/<example>.md. --scaling sets density_scaling for every variant (default 1:
none; the README says which was used); --jobs runs that many at once, each with --threads threads;
--set adds a line to the test's table (side_views = 4); --timeout stops a run after so many
seconds and reports how far it came (its curve so far is in its curve_progress.csv).
"""
import json
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
FILES = {
    "shear": "stalk_shear.toml",
    "compression": "stalk_compression.toml",
    "safflower": "safflower_neck_shear.toml",
}


def sub(pattern, repl, count=0):
    """A variant that replaces a regular expression everywhere in the file (it must match)."""

    def edit(text):
        new, n = re.subn(pattern, repl, text, count=count, flags=re.M)
        if n == 0:
            raise SystemExit(f"variant pattern {pattern!r} matches nothing")
        return new

    return edit


def table_key(table, line):
    """A variant that adds `line` at the top of [table]."""
    return sub(rf"^\[{table}\]$", f"[{table}]\n{line}", count=1)


def chain(*edits):
    def edit(text):
        for e in edits:
            text = e(text)
        return text

    return edit


BOND_BLOCK_END = r"^(contact_radius(_scale)? = .*)$"

VARIANTS = {
    "shear": {
        "published": chain(),
        # EDEM's bonded disk scale applies to the smaller radius; the contact radius (0.6 mm) is
        # the other radius a reader might take for R_B.
        "bond-radius-0.6mm": sub(r"^bonded_disk_scale = 1\.0$", "bond_radius = 0.0006"),
        # EDEM takes a shear modulus: 95.94 MPa typed there is E = 259 MPa.
        "modulus-as-G": sub(r"^youngs_modulus = 95\.94e6$", "shear_modulus = 95.94e6"),
        "contacts-10x-stiffer": sub(r"^youngs_modulus = 95\.94e6$", "youngs_modulus = 959.4e6"),
        # EDEM's 4 235 spheres, 4.5 bonds per sphere: a random packing at its count.
        "random-packing": sub(r'packing = "hcp", spacing = 0\.001', 'packing = "random", count = 4235'),
        "stiffness-range-0.5": sub(BOND_BLOCK_END, r"\1\nstiffness_range = 0.5"),
        "unclamped": table_key("shear", "clamped = false"),
        "thin-blade-tight-slot": chain(
            sub(r"^blade_thickness = 0\.001$", "blade_thickness = 0.0005"),
            sub(r"^slot_width = 0\.0015$", "slot_width = 0.0006"),
        ),
        "step-20-percent": sub(r"^time_step_percent = 10$", "time_step_percent = 20"),
        # Not faithful: what the bonds would need to fail early.
        "shear-stiff-bonds": sub(r"^shear_stiffness = 1\.28e8$", "shear_stiffness = 5.12e9"),
        "bonds-10x-weaker": chain(
            sub(r"^critical_normal_stress = 1\.60e7$", "critical_normal_stress = 1.60e6"),
            sub(r"^critical_shear_stress = 2\.48e6$", "critical_shear_stress = 2.48e5"),
        ),
    },
    "compression": {
        "published": chain(),
        # 6.285e6 N/m^3 read as per mm^3 of area and length (the paper gives A in mm^2): 1e9 x.
        "bond-stiffness-1e3x": sub(r"^normal_stiffness = 6\.285e6$", "normal_stiffness = 6.285e9"),
        "bond-stiffness-1e6x": sub(r"^normal_stiffness = 6\.285e6$", "normal_stiffness = 6.285e12"),
        "bond-radius-1mm": sub(r"^bond_radius = 0\.002$", "bond_radius = 0.001"),
        "contact-radius-1.3": sub(r"^contact_radius_scale = 1\.1$", "contact_radius_scale = 1.3"),
    },
    "safflower": {
        # The example: D_1 = 4.85 mm and Poisson 0.25 (published), G = 7 MPa (fitted).
        "example": chain(),
        # The example before issue 37: a 4 mm neck of the corn stalk's material.
        "4mm-corn-stalk-material": chain(
            sub(r"diameter = 0\.00485 \}", "diameter = 0.004 }"),
            sub(r"^poisson_ratio = 0\.25\nshear_modulus = 7e6$", "poisson_ratio = 0.35\nyoungs_modulus = 95.94e6"),
        ),
        "corn-stalk-material": sub(
            r"^poisson_ratio = 0\.25\nshear_modulus = 7e6$", "poisson_ratio = 0.35\nyoungs_modulus = 95.94e6"
        ),
        # Everything the paper gives: its measured G = 1 MPa (at 10 % of the Rayleigh step, and at
        # 3 %, which the bonds take against such soft spheres).
        "paper-material": sub(r"^shear_modulus = 7e6$", "shear_modulus = 1e6"),
        "paper-material-3-percent": chain(
            sub(r"^shear_modulus = 7e6$", "shear_modulus = 1e6"),
            sub(r"^time_step_percent = 10$", "time_step_percent = 3"),
        ),
        "G-5MPa": sub(r"^shear_modulus = 7e6$", "shear_modulus = 5e6"),
        "G-10MPa": sub(r"^shear_modulus = 7e6$", "shear_modulus = 1e7"),
        "bond-radius-0.2mm": sub(r"^bond_radius = 0\.0003$", "bond_radius = 0.0002"),
        "bond-radius-0.4mm": sub(r"^bond_radius = 0\.0003$", "bond_radius = 0.0004"),
        "unclamped": table_key("shear", "clamped = false"),
    },
}


def run(demcal, example, name, out, threads, scaling, extra, timeout=None):
    text = (HERE.parent / FILES[example]).read_text()
    text = VARIANTS[example][name](text)
    # The examples carry density_scaling = 100; --scaling replaces it (1 removes it).
    text = re.sub(r"^density_scaling = .*\n", "", text, flags=re.M)
    if scaling and scaling != 1:
        text = re.sub(r'^(test = ".*")$', rf"\1\ndensity_scaling = {scaling:g}", text, count=1, flags=re.M)
    table = "shear" if example != "compression" else "compression"
    for line in extra:
        key = line.split("=")[0].strip()
        if re.search(rf"^{key} = ", text, flags=re.M):
            text = re.sub(rf"^{key} = .*$", line, text, flags=re.M)
        else:
            text = re.sub(rf"^\[{table}\]$", f"[{table}]\n{line}", text, count=1, flags=re.M)
    folder = out / f"{example}-{name}"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "test.toml"
    path.write_text(text)
    cmd = [demcal, "test", str(path), "--out", str(folder / "out"), "--json"]
    if threads:
        cmd += ["--threads", str(threads)]
    start = time.time()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        # What the run measured so far is in its curve_progress.csv.
        wall = time.time() - start
        rows = (folder / "out" / "curve_progress.csv").read_text().splitlines()[1:]
        last = rows[-1].split(",") if rows else ["0", "0"]
        peak = max((float(r.split(",")[1]) for r in rows), default=0.0)
        return name, None, wall, (
            f"stopped by --timeout at {1e3 * float(last[0]):.2f} mm of travel "
            f"(largest force so far {peak:.1f} N, {last[-1]} bonds broken)"
        )
    wall = time.time() - start
    (folder / "log.txt").write_text(p.stdout + p.stderr)
    if p.returncode != 0:
        return name, None, wall, (p.stderr.strip().splitlines() or ["?"])[-1]
    return name, json.loads(p.stdout.strip().splitlines()[-1]), wall, ""


def row(name, r, wall, error):
    if r is None:
        return f"| {name} | {error} |  |  |  |  |  |  | {wall:.0f} |"
    o = r["overlaps"]
    b = r.get("bond_stress_at_peak") or {}
    return (
        f"| {name} | {r['peak_force_n']:.1f} | {1e3 * r['displacement_at_peak_m']:.2f} | "
        f"{r['mean_force_n']:.1f} | {r['bonds_broken']} of {r['bonds']} | "
        f"{b.get('max_tension_ratio', 0):.2f} / {b.get('max_shear_ratio', 0):.2f} | "
        f"{o['spheres']['relative']:.2f} / {o['geometry']['relative']:.2f} | "
        f"{r['kinetic_to_work_ratio']:.1e} / {r['unbalanced_force_ratio']:.1e} | {wall:.0f} |"
    )


def main(argv):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("demcal")
    ap.add_argument("example", choices=sorted(FILES))
    ap.add_argument("out", type=Path)
    ap.add_argument("variants", nargs="*")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--scaling", type=float, default=1.0)
    ap.add_argument("--set", action="append", default=[], help="a line added to the test's table")
    ap.add_argument("--timeout", type=float, help="seconds a run may take (its curve so far is kept)")
    a = ap.parse_args(argv)
    names = a.variants or list(VARIANTS[a.example])
    with ThreadPoolExecutor(a.jobs) as pool:
        results = list(
            pool.map(lambda n: run(a.demcal, a.example, n, a.out, a.threads, a.scaling, a.set, a.timeout), names)
        )
    lines = [
        f"{a.example}, density_scaling = {a.scaling:g}",
        "",
        "| variant | peak (N) | at (mm) | mean (N) | bonds broken | sigma/sigma_c, tau/tau_c at peak (max) | largest overlap / R: spheres, geometry | kinetic / work, net force / peak | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ] + [row(*r) for r in results]
    text = "\n".join(lines) + "\n"
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / f"{a.example}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main(sys.argv[1:])
