#!/usr/bin/env python3
"""Reference ANOVA numbers for crates/doe/tests/statsmodels.rs.

Writes three data sets to crates/doe/tests/data/ (seeded, so re-running gives the same files) and
prints statsmodels' type III ANOVA of each, which the Rust test embeds. Needs numpy, pandas and
statsmodels (pip install statsmodels). Run from the repository root:

    python3 tools/doe/statsmodels_anova.py
"""
import itertools
import os

import numpy as np
import pandas as pd
import statsmodels.formula.api as smf
from statsmodels.stats.anova import anova_lm

OUT = "crates/doe/tests/data"
rng = np.random.default_rng(20261121)


def box_behnken_3():
    runs = []
    for i, j in itertools.combinations(range(3), 2):
        for a, b in itertools.product([-1, 1], repeat=2):
            r = [0, 0, 0]
            r[i], r[j] = a, b
            runs.append(r)
    runs += [[0, 0, 0]] * 3
    x = np.array(runs, float)
    A, B, C = x.T
    y = 30 + 2.5 * A - 1.2 * B + 0.8 * C + 1.5 * A * B + 2.0 * A**2 - 0.9 * C**2
    y = y + rng.normal(0, 0.6, len(y))
    return pd.DataFrame({"A": A, "B": B, "C": C, "y": y}), "A + B + C + A:B + A:C + B:C + I(A**2) + I(B**2) + I(C**2)"


def factorial_replicated_unbalanced():
    x = np.array(list(itertools.product([-1, 1], repeat=3)) * 2, float)
    x = np.delete(x, 5, axis=0)  # one run lost: unbalanced, so the types of SS differ
    A, B, C = x.T
    y = 10 + 1.1 * A + 0.4 * B - 0.7 * C + 0.6 * A * C + rng.normal(0, 0.5, len(A))
    return pd.DataFrame({"A": A, "B": B, "C": C, "y": y}), "A + B + C + A:B + A:C + B:C"


def scattered_four_factors():
    n = 30
    x = rng.uniform(-1, 1, (n, 4))
    A, B, C, D = x.T
    y = 5 + 0.8 * A - 0.5 * B + 0.3 * C + 0.05 * D + 0.6 * A * B + 0.9 * A**2 - 0.4 * C**2
    y = y + rng.normal(0, 0.25, n)
    return (
        pd.DataFrame({"A": A, "B": B, "C": C, "D": D, "y": y}),
        "A + B + C + D + A:B + I(A**2) + I(C**2)",
    )


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, make in [
        ("bbd3", box_behnken_3),
        ("factorial_unbalanced", factorial_replicated_unbalanced),
        ("scattered4", scattered_four_factors),
    ]:
        df, formula = make()
        path = f"{OUT}/{name}.csv"
        df.to_csv(path, index=False, float_format="%.6f")
        df = pd.read_csv(path)  # fit what the test reads
        fit = smf.ols("y ~ " + formula, data=df).fit()
        table = anova_lm(fit, typ=3)
        print(f"== {name}: y ~ {formula}")
        for term, r in table.iterrows():
            f = "" if np.isnan(r["F"]) else f"{r['F']:.10g}"
            p = "" if np.isnan(r["PR(>F)"]) else f"{r['PR(>F)']:.10g}"
            print(f"{term:12s} sum_sq={r['sum_sq']:.10g} df={r['df']:.0f} F={f} p={p}")
        print(f"r2={fit.rsquared:.10g} adj_r2={fit.rsquared_adj:.10g}")


if __name__ == "__main__":
    main()
