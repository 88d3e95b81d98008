"""Designed experiments, as `demcal doe design | analyze | optimize` (Design-Expert's part).

    runs = demcal.doe.design("ccd", "mu_s:0.2:0.8,mu_r:0.05:0.25", center_points=5)
    fit = demcal.doe.analyze(table, "angle_deg", factors="mu_s:0.2:0.8,mu_r:0.05:0.25")
    fit.anova        # Design-Expert's ANOVA rows: source, sum_sq, df, mean_sq, f, p
    fit.r2, fit.coefficients_actual

Tables are a CSV file's path, a pandas DataFrame, a dict of columns or a list of row dicts.
Factors are written as on the command line: `name:low:high[:log]` for columns in actual units,
or plain names for coded columns.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Union

from . import _demcal
from ._tables import TableLike, frame_or_rows, rows_from_csv, table_args
from .errors import InputError, whole

KINDS = ("plackett-burman", "factorial", "fractional", "ccd", "box-behnken", "lhs", "random", "steepest")


def _factor_spec(factors: Union[str, int, Sequence[Any], Dict[str, Sequence[float]]]) -> str:
    """`"a:0:1,b:2:3"`, a count, a list of names or specs, or {name: (low, high)}."""
    if isinstance(factors, str):
        return factors
    if isinstance(factors, int):
        return str(factors)
    if isinstance(factors, dict):
        return ",".join(
            f"{n}:{r[0]}:{r[1]}" + (":log" if len(r) > 2 and r[2] == "log" else "") for n, r in factors.items())
    return ",".join(str(f) for f in factors)


@dataclass
class Design:
    """A design in run order: `rows` (std_order, run_order, point_type, coded columns and
    `<name>_actual` columns), the `factors`' names and the `summary` `demcal doe design` prints."""

    rows: List[Dict[str, Any]]
    factors: List[str]
    summary: str

    def actual(self) -> List[Dict[str, float]]:
        """Each run's factor settings in actual units, by factor name."""
        return [{f: r[f + "_actual"] for f in self.factors} for r in self.rows]

    def frame(self) -> Any:
        """The rows as a pandas DataFrame (needs pandas)."""
        return frame_or_rows(self.rows, True)

    def __len__(self) -> int:
        return len(self.rows)


def design(kind: str, factors: Union[str, int, Sequence[Any], Dict[str, Sequence[float]]], *,
           center_points: Optional[int] = None, alpha: Optional[Union[str, float]] = None,
           runs: Optional[int] = None, resolution: Optional[int] = None, fraction: Optional[int] = None,
           half_fraction: Optional[bool] = None, lhs: Optional[str] = None,
           direction: Optional[Union[str, Sequence[float]]] = None, step: Optional[float] = None,
           seed: int = 1) -> Design:
    """A design of `kind` (`plackett-burman`/`pb`, `factorial`, `fractional`, `ccd`,
    `box-behnken`/`bbd`, `lhs`, `random`, `steepest`) over `factors`, with the options of
    `demcal doe design` (`alpha`: rotatable, spherical, face, orthogonal, inscribed or a number;
    `direction`: a steepest path's coefficients)."""
    spec = _factor_spec(factors)
    if direction is not None and not isinstance(direction, str):
        direction = ",".join(str(float(v)) for v in direction)
    center_points, runs = whole("center_points", center_points, 0), whole("runs", runs, 1)
    resolution, fraction = whole("resolution", resolution, 1), whole("fraction", fraction, 1)
    seed = whole("seed", seed, 0)
    a = json.loads(_demcal.doe_design(
        kind, spec, center_points, None if alpha is None else str(alpha), runs, resolution, fraction,
        half_fraction, lhs, direction, step, seed))
    rows = rows_from_csv(a["csv"])
    names = [c for c in (rows[0].keys() if rows else []) if c.endswith("_actual")]
    return Design(rows=rows, factors=[c[: -len("_actual")] for c in names], summary=a["summary"])


@dataclass
class Analysis:
    """One response's fitted model with Design-Expert's ANOVA.

    `anova` lists the rows as Design-Expert prints them (Model, each term, Curvature, Residual,
    Lack of Fit, Pure Error, Cor Total), each a dict `source, sum_sq, df, mean_sq, f, p`
    (`f`, `p` None where they do not apply). `raw` is everything `demcal doe analyze --json`
    gives (coefficients with standard errors, intervals and VIFs, effects, removed terms)."""

    response: str
    anova: List[Dict[str, Any]]
    r2: float
    adj_r2: float
    pred_r2: Optional[float]
    adeq_precision: Optional[float]
    std_dev: float
    mean: float
    cv_percent: float
    press: Optional[float]
    coefficients: List[Dict[str, Any]]
    coefficients_coded: Dict[str, float]
    coefficients_actual: Optional[Dict[str, float]]
    raw: Dict[str, Any] = field(repr=False)

    def anova_frame(self) -> Any:
        """The ANOVA table as a pandas DataFrame (needs pandas)."""
        return frame_or_rows(self.anova, True)

    def p(self, source: str) -> Optional[float]:
        """The p-value of a row (`"Model"`, `"A"`, `"AB"`, `"Lack of Fit"`, ...)."""
        for r in self.anova:
            if r["source"] == source:
                return r["p"]
        raise KeyError(f"{source!r}: no such row (rows: {', '.join(r['source'] for r in self.anova)})")


def _row(source: str, r: Optional[Dict[str, Any]]) -> Optional[Dict[str, Any]]:
    if not r:
        return None
    return {"source": source, "sum_sq": r.get("sum_sq"), "df": r.get("df"), "mean_sq": r.get("mean_sq"),
            "f": r.get("f"), "p": r.get("p")}


def _analysis(j: Dict[str, Any]) -> Analysis:
    rows = [_row("Model", j["model"])]
    rows += [_row(t["name"], t) for t in j["terms"]]
    rows += [_row("Curvature", j.get("curvature")), _row("Residual", j.get("residual")),
             _row("Lack of Fit", j.get("lack_of_fit")), _row("Pure Error", j.get("pure_error"))]
    total = j.get("total") or {}
    rows.append({"source": "Cor Total", "sum_sq": total.get("sum_sq"), "df": total.get("df"),
                 "mean_sq": None, "f": None, "p": None})
    return Analysis(
        response=j["response"], anova=[r for r in rows if r is not None], r2=j["r2"], adj_r2=j["adj_r2"],
        pred_r2=j.get("pred_r2"), adeq_precision=j.get("adeq_precision"), std_dev=j["std_dev"],
        mean=j["mean"], cv_percent=j["cv_percent"], press=j.get("press"), coefficients=j["coefficients"],
        coefficients_coded=j["coefficients_coded"], coefficients_actual=j.get("coefficients_actual"), raw=j)


def analyze(data: TableLike, response: Union[str, Sequence[str]], *, factors: Optional[str] = None,
            model: Optional[str] = None, reduce: bool = False, alpha_out: float = 0.10,
            hierarchy: bool = True, curvature: bool = True, plots: Optional[str] = None) -> Any:
    """Fits `response` (or each of several) as `demcal doe analyze` does: `model` linear, 2fi,
    quadratic, cubic, mean or a term list (linear for two-level data, quadratic otherwise when
    None); `reduce` for backward elimination at `alpha_out`; `plots` a folder for the plots.
    Returns an `Analysis` for a response named by a str, a list of them for a list of names."""
    responses = [response] if isinstance(response, str) else list(response)
    path, csv, source = table_args(data)
    out = json.loads(_demcal.doe_analyze(responses, path, csv, source, factors, model, reduce, alpha_out,
                                         not hierarchy, not curvature, plots))
    fits = [_analysis(j) for j in out] if isinstance(out, list) else [_analysis(out)]
    return fits[0] if isinstance(response, str) else fits


_GOAL_WORDS = ("maximize", "max", "minimize", "min", "target", "range", "in_range")


def _goal_responses(goals: Sequence[str], factors: Optional[str]) -> List[str]:
    """The response columns the goals name, when `responses` is not given: every goal's column
    but the factors'. A goal on a factor (`"D:range:lower=-0.5:upper=0.5"`) cannot be told from
    one on a response without `factors`, so several goals need `factors` or `responses`."""
    names = []
    for g in goals:
        head = g.split(":", 1)[0].strip()
        if head.split("=", 1)[0] in _GOAL_WORDS:
            raise InputError(f"goal '{g}' names no column: write it as NAME:GOAL, or give responses=[...]")
        names.append(head)
    factor_names = {f.split(":", 1)[0].strip() for f in factors.split(",")} if factors else set()
    responses = [n for n in names if n not in factor_names]
    if not responses:
        raise InputError(f"goals {goals}: each names a factor ({factors}); give responses=[...] too")
    if len(names) > 1 and not factors:
        raise InputError(
            f"goals on {', '.join(names)}: say which columns are responses (responses=[...]) or which are "
            "factors (factors=...); a goal may be on either")
    return responses


def optimize(data: TableLike, goals: Union[str, Sequence[str], Dict[str, str]], *,
             responses: Optional[Sequence[str]] = None, factors: Optional[str] = None,
             model: Optional[str] = None, reduce: bool = False, alpha_out: float = 0.10,
             solutions: int = 10, starts: int = 100, seed: int = 1) -> Dict[str, Any]:
    """Desirability optimisation over the fitted models, as `demcal doe optimize --json`.

    `goals` as on the command line (`"angle_deg:target=38.65"`, `"error:minimize:upper=5"`, a
    factor's `"D:range:lower=-0.5:upper=0.5"`), or {column: goal} (`{"angle_deg": "target=38.65"}`).
    `responses` (the CLI's `--response`) defaults to the goals' columns less those named in
    `factors`; with several goals give `responses` or `factors`, since a goal may be on either
    (`InputError` otherwise). Returns the solutions (each factor's setting, each response's
    prediction and desirability) as `demcal doe optimize --json` gives them."""
    if isinstance(goals, str):
        goals = [goals]
    elif isinstance(goals, dict):
        goals = [f"{k}:{v}" for k, v in goals.items()]
    goals = list(goals)
    if responses is None:
        responses = _goal_responses(goals, factors)
    solutions, starts, seed = whole("solutions", solutions, 1), whole("starts", starts, 1), whole("seed", seed, 0)
    path, csv, source = table_args(data)
    return json.loads(_demcal.doe_optimize(list(responses), goals, path, csv, source, factors, model, reduce,
                                           alpha_out, solutions, starts, seed))
