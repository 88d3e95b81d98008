#!/usr/bin/env python3
"""Compares force-displacement curves the way the seed-000 paper scores a simulation against the lab:
forces divided by the reference curve's peak, both interpolated linearly at 1000 evenly spaced
displacements over the range they share, and the mean squared difference (the paper's MSE, as a
study's `curve_mse` with `normalisation = "lab_peak"`). Also the peaks over that range. Writes an
SVG overlay of the curves.

    python3 examples/stalks/investigation/compare.py OUT.svg REFERENCE.csv LABEL [CURVE.csv LABEL ...]

Each CSV is a mechanical test's force_displacement.csv (displacement_m,force_n) or its
curve_progress.csv (travel_m,force_n,...). Prints one line per curve against the reference.
"""
import sys

COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"]


def read(path):
    rows = []
    with open(path) as f:
        next(f)
        for line in f:
            parts = line.strip().split(",")
            if len(parts) >= 2:
                rows.append((float(parts[0]), float(parts[1])))
    return rows


def interp(rows, x):
    lo, hi = 0, len(rows) - 1
    if x <= rows[0][0]:
        return rows[0][1]
    if x >= rows[-1][0]:
        return rows[-1][1]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if rows[mid][0] <= x:
            lo = mid
        else:
            hi = mid
    (x0, y0), (x1, y1) = rows[lo], rows[hi]
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0) if x1 > x0 else y0


def svg(path, curves):
    w, h, m = 800, 480, 60
    xmax = max(r[-1][0] for _, r in curves) * 1e3
    ymax = max(max(y for _, y in r) for _, r in curves) * 1.05
    sx = lambda x: m + (w - 2 * m) * x * 1e3 / xmax
    sy = lambda y: h - m - (h - 2 * m) * y / ymax
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="13">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<line x1="{m}" y1="{h - m}" x2="{w - m}" y2="{h - m}" stroke="black"/>',
           f'<line x1="{m}" y1="{m}" x2="{m}" y2="{h - m}" stroke="black"/>',
           f'<text x="{w / 2}" y="{h - 20}" text-anchor="middle">displacement (mm)</text>',
           f'<text x="18" y="{h / 2}" transform="rotate(-90 18 {h / 2})" text-anchor="middle">force (N)</text>']
    for k in range(6):
        x, y = xmax * k / 5, ymax * k / 5
        out.append(f'<text x="{sx(x / 1e3):.1f}" y="{h - m + 18}" text-anchor="middle">{x:.1f}</text>')
        out.append(f'<text x="{m - 6}" y="{sy(y) + 4:.1f}" text-anchor="end">{y:.0f}</text>')
    for i, (label, rows) in enumerate(curves):
        c = COLOURS[i % len(COLOURS)]
        pts = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in rows)
        dash = ' stroke-dasharray="6 3"' if i else ""
        out.append(f'<polyline fill="none" stroke="{c}" stroke-width="1.5"{dash} points="{pts}"/>')
        out.append(f'<text x="{m + 12}" y="{m + 18 * (i + 1)}" fill="{c}">{label}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main(argv):
    out, ref_path, ref_label = argv[0], argv[1], argv[2]
    ref = read(ref_path)
    curves = [(ref_label, ref)]
    pairs = list(zip(argv[3::2], argv[4::2]))
    for path, label in pairs:
        rows = read(path)
        end = min(ref[-1][0], rows[-1][0])
        xs = [end * k / 999 for k in range(1000)]
        peak_ref = max(y for x, y in ref if x <= end)
        peak = max(y for x, y in rows if x <= end)
        mse = sum((interp(rows, x) / peak_ref - interp(ref, x) / peak_ref) ** 2 for x in xs) / len(xs)
        print(
            f"{label} against {ref_label} over 0-{1e3 * end:.2f} mm: MSE {mse:.2e} (forces over the reference peak), "
            f"peak {peak:.1f} N against {peak_ref:.1f} N ({100 * (peak / peak_ref - 1):+.2f} %)"
        )
        curves.append((label, rows))
    svg(out, curves)


if __name__ == "__main__":
    main(sys.argv[1:])
