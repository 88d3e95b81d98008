# %% [markdown]
# # A stalk shear test's force-displacement curve, plotted with matplotlib
#
# Runs the corn stalk shear test of `examples/stalks/stalk_shear.toml` (a 15 mm silage maize
# internode, 4 313 bonded spheres, cut by a blade through a slotted support) in-process and plots
# the force against the blade's travel, with the peak marked.
#
# The file as written takes 15-20 minutes on 2 cores (16 mm of travel at density scaling 100), so
# by default the script edits the test, through `Test.to_dict` / `Test.from_dict`, before it runs:
#
# - `density_scaling` 100 -> 1e4: every sphere 100 times heavier again, a time step 10 times
#   longer. examples/stalks/README.md checked this against the unscaled run: over the first 2 mm
#   F = 1e4 matches F = 1 with a curve MSE of 3.2e-6 and a peak 1.7 % lower. demcal checks every
#   run for quasi-static loading (kinetic energy against the work done, net force against the
#   peak) and raises `demcal.NotQuasiStaticError` when it fails: at F = 1e4 that happens over
#   the first 1 mm alone (kinetic energy 8.5 % of the work, limit 5 %; 1.1 % over 1.5 mm) and,
#   by that README, in the saw-tooth phase after about 10 mm;
# - `max_displacement` 16 mm -> 5 mm (1.5 mm with `--quick`): the first third of the curve,
#   under a minute on 2 cores (at 5 mm the README's unscaled run reads 112.5 N);
# - `side_views` removed: this script draws no pictures of the specimen (they are written by
#   `Test.run(out=...)`).
#
# At the published bonds no bond breaks in the first millimetres (the README beside the file
# explains why), so over 5 mm the force only rises and the "peak" is the last point. For a curve
# with a peak inside the travel, run the safflower neck shear as written (about 7 s):
#
#     python python/examples/plot_shear_curve.py                        # writes shear_curve.png here
#     python python/examples/plot_shear_curve.py /tmp/curve.png --travel-mm 8
#     python python/examples/plot_shear_curve.py neck.png --test examples/stalks/safflower_neck_shear.toml
#     python python/examples/plot_shear_curve.py --quick                # 1.5 mm, for the tests
#     python python/examples/plot_shear_curve.py --as-written           # the file unchanged (15-20 min)

# %%
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # write a file; no display needed
import matplotlib.pyplot as plt

import demcal

HERE = Path(__file__).resolve().parent
STALKS = HERE.parents[1] / "examples" / "stalks"
CORN_STALK = STALKS / "stalk_shear.toml"

# The quicker corn-stalk run (see the header for why each is safe).
CORN_STALK_EDITS = {"density_scaling": 1e4, "travel_mm": 5.0}


# %% [markdown]
# ## The test, edited through its dict
#
# `Test.to_dict()` gives the test file's contents (a copy); change it and build a new `Test` with
# `Test.from_dict`. `folder` keeps relative paths in the file (an STL, a lab curve) working.


# %%
def make_test(path: Path, density_scaling: float | None, travel_mm: float | None) -> tuple[demcal.Test, list]:
    test = demcal.Test.load(path)
    if density_scaling is None and travel_mm is None:
        return test, []
    table = test.to_dict()
    section = table[test.kind]  # the test's own table: [shear]
    changes = []
    if density_scaling is not None:
        changes.append(f"density scaling {table.get('density_scaling', 1):g} -> {density_scaling:g}")
        table["density_scaling"] = density_scaling
    if travel_mm is not None:
        changes.append(f"travel {1000 * section['max_displacement']:g} -> {travel_mm:g} mm")
        section["max_displacement"] = travel_mm / 1000
    section.pop("side_views", None)
    return demcal.Test.from_dict(table, folder=path.parent, name=f"{path.name} (edited)"), changes


# %% [markdown]
# ## The plot
#
# `Result.curves["force_displacement"]` is a `demcal.Curve`: numpy `x` and `y` with their names
# and units, and `peak` (the largest force). The displacement is in metres; it is plotted in mm.


# %%
def plot(result: demcal.Result, png: Path, title: str, note: str) -> dict:
    curve = result.curves["force_displacement"]
    scale, x_unit = (1000.0, "mm") if curve.x_unit == "m" else (1.0, curve.x_unit)
    x, y = curve.x * scale, curve.y
    i = int(y.argmax())
    at_end = i >= len(y) - 2  # the force still rising when the travel ended

    fig, ax = plt.subplots(figsize=(7, 4.4), dpi=150)
    ax.plot(x, y, color="tab:blue", lw=1.4, label="simulated")
    ax.plot(x[i], y[i], "o", color="tab:red", ms=7, zorder=3,
            label="largest force (end of travel)" if at_end else "peak force")
    left = x[i] > 0.6 * x.max()  # label on the side with room
    ax.annotate(f"{curve.peak:.1f} {curve.y_unit} at {x[i]:.2f} {x_unit}",
                xy=(x[i], y[i]), xytext=(-10, 6) if left else (10, 6), textcoords="offset points",
                ha="right" if left else "left", va="bottom", fontsize=9)
    ax.set_xlabel(f"blade {curve.x_name} ({x_unit})")
    ax.set_ylabel(f"{curve.y_name} ({curve.y_unit})")
    ax.set_xlim(0, x.max() * 1.02)
    ax.set_ylim(0, y.max() * 1.15)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=9)
    ax.set_title(title, fontsize=11)
    fig.text(0.01, 0.01, note, fontsize=7.5, color="0.35", ha="left", va="bottom")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png)
    plt.close(fig)
    return {"peak_force_n": curve.peak, "displacement_at_peak_mm": float(x[i]), "peak_at_end": at_end,
            "points": len(curve)}


# %%
def main(argv=None) -> dict:
    if argv is None and "ipykernel" in sys.modules:
        argv = []
    ap = argparse.ArgumentParser(description="Run a stalk shear test and plot its force-displacement curve.")
    ap.add_argument("png", nargs="?", type=Path, default=HERE / "shear_curve.png",
                    help="the picture to write (default shear_curve.png next to this script)")
    ap.add_argument("--test", type=Path, default=CORN_STALK, help="a shear test file (default the corn stalk)")
    ap.add_argument("--travel-mm", type=float, help="blade travel (default 5 mm for the corn stalk)")
    ap.add_argument("--density-scaling", type=float, help="density scaling (default 1e4 for the corn stalk)")
    ap.add_argument("--quick", action="store_true", help="1.5 mm of travel: for the tests")
    ap.add_argument("--as-written", action="store_true", help="run the file unchanged")
    ap.add_argument("--threads", type=int, default=2, help="cores for the simulation (default 2)")
    ap.add_argument("--json", type=Path, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)

    path = args.test.resolve()
    scaling, travel = args.density_scaling, args.travel_mm
    if not args.as_written and path == CORN_STALK.resolve():
        scaling = CORN_STALK_EDITS["density_scaling"] if scaling is None else scaling
        travel = CORN_STALK_EDITS["travel_mm"] if travel is None else travel
    if args.quick and not args.as_written:
        travel = 1.5
    if args.as_written:
        scaling = travel = None
    test, changes = make_test(path, scaling, travel)
    print(f"{path}: {test.kind} test" + (f", edited: {', '.join(changes)}" if changes else ", as written"))

    result = test.run(seed=1, threads=args.threads)  # a failed run raises a demcal.RunError
    print(result.summary)

    title = f"{path.name}: {test.kind} force against blade travel"
    note = (f"demcal {demcal.__version__}, {path.name}" + (f" ({', '.join(changes)})" if changes else "")
            + f"; {int(result.responses.get('bonds_broken', 0))} bonds broken; run {result.wall_s:.0f} s")
    png = args.png.resolve()
    numbers = plot(result, png, title, note)
    numbers.update({"png": str(png), "test": str(path), "changes": changes, "wall_s": result.wall_s,
                    "responses": result.responses})
    print(f"peak {numbers['peak_force_n']:.2f} N at {numbers['displacement_at_peak_mm']:.3f} mm"
          + (" (the end of the travel: still rising)" if numbers["peak_at_end"] else "")
          + f"; run {result.wall_s:.1f} s; wrote {png}")
    if args.json:
        args.json.write_text(json.dumps(numbers, indent=2))
    return numbers


if __name__ == "__main__":
    main()
