"""Surrogate models, as `demcal surrogate fit | optimize`: a Gaussian process (Matern 5/2 or
squared exponential), a BP network or a GA-BP network on a result table.

    gp = demcal.surrogate.fit(table, "angle_deg", factors=["mu_s", "mu_r"])
    mean, var = gp.predict([[0.5, 0.1], [0.6, 0.12]])
    best = demcal.surrogate.optimize(table, "angle_deg", "target=27.35", model="ga-bp")
"""

from __future__ import annotations

import json
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _demcal
from ._tables import TableLike, table_args
from .errors import whole


class Surrogate:
    """A fitted surrogate. `predict` takes rows of factor values in actual units."""

    def __init__(self, native: Any) -> None:
        self._native = native
        info = json.loads(native.summary_json)
        #: The factor columns, in the order `predict` takes them.
        self.factors: List[str] = list(native.factors)
        #: Each factor's observed (minimum, maximum): the box the model is fitted in.
        self.ranges: List[Tuple[float, float]] = [tuple(r) for r in native.ranges]
        self.model: str = info["model"]
        self.response: str = info["response"]
        #: Metrics (r2, rmse, mae, n) on the training, validation, test rows and all of them,
        #: and facts about the model (length scales, noise, epochs) under "details".
        self.info: Dict[str, Any] = info

    def predict(self, x: Union[Sequence[Sequence[float]], np.ndarray, Dict[str, Any]]) -> Tuple[np.ndarray, np.ndarray]:
        """Mean and variance at each row of `x` (n x factors, or a dict / DataFrame with the
        factor columns). The variance is a GP's posterior variance of the mean (noise not
        included) or a network ensemble's spread; NaN for a single network."""
        if hasattr(x, "columns") or isinstance(x, dict):
            table: Any = x
            x = np.column_stack([np.asarray(table[f], dtype=float) for f in self.factors])
        arr = np.asarray(x, dtype=float)
        if arr.size == 0:
            return np.zeros(0), np.zeros(0)
        if arr.ndim == 1:
            # One row of factor values; for a one-factor model, a column of them.
            arr = arr.reshape(-1, 1) if len(self.factors) == 1 else arr.reshape(1, -1)
        pairs = self._native.predict(arr.tolist())
        mean = np.array([m for m, _ in pairs], dtype=float)
        var = np.array([np.nan if v is None else v for _, v in pairs], dtype=float)
        return mean, var

    def __repr__(self) -> str:
        return f"Surrogate({self.model!r} of {self.response!r} on {self.factors})"


def _factor_list(factors: Union[None, str, Sequence[str]]) -> Optional[List[str]]:
    """Factor columns as a list: a list of names, or one string `"D,E,G"` as the command line
    and `doe` take them."""
    if factors is None:
        return None
    if isinstance(factors, str):
        return [f.strip() for f in factors.split(",") if f.strip()]
    return [str(f) for f in factors]


def fit(data: TableLike, response: str, *, factors: Union[None, str, Sequence[str]] = None, model: str = "gp",
        kernel: Optional[str] = None, seed: int = 1, train_fraction: float = 0.8) -> Surrogate:
    """Fits a surrogate of `response` on the other columns (or `factors`): `model` gp, bp or
    ga-bp; `kernel` matern52 (the default) or squared_exponential (`rbf`) for a GP;
    `train_fraction` of the rows trained on, the rest kept to test it (as the papers' 80/20)."""
    seed = whole("seed", seed, 0)
    path, csv, source = table_args(data)
    native = _demcal.surrogate_fit(response, path, csv, source, _factor_list(factors), model,
                                   kernel, seed, train_fraction)
    return Surrogate(native)


def optimize(data: TableLike, response: str, goal: str = "minimize", *, factors: Union[None, str, Sequence[str]] = None,
             model: str = "gp", kernel: Optional[str] = None, seed: int = 1, train_fraction: float = 0.8,
             target_of: Optional[str] = None, value: Optional[float] = None) -> Dict[str, Any]:
    """Fits, then searches the model with a genetic algorithm inside the table's ranges
    (GA-BP-GA for `model="ga-bp"`), as `demcal surrogate optimize --json`: `goal` minimize,
    maximize or `target=V`; `target_of` and `value` minimise the relative error of a response
    column against a lab value by modelling the response. Returns the `solution` (each factor's
    value), the `predicted` value and the model's metrics."""
    seed = whole("seed", seed, 0)
    path, csv, source = table_args(data)
    return json.loads(_demcal.surrogate_optimize(response, goal, path, csv, source,
                                                 _factor_list(factors), model, kernel,
                                                 seed, train_fraction, target_of, value))
