"""demcal.surrogate: a Gaussian process on a smooth function (mean and variance where the data
are and away from them, the metrics), the networks, the genetic search for a known optimum, and
`demcal surrogate optimize --json` from Python."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import demcal
from demcal import surrogate

from conftest import REPO

CCD = REPO / "crates" / "doe" / "tests" / "data" / "silage-repose-ccd.csv"


def bowl(x1, x2):
    """Smooth, with its only minimum, 1, at (0.3, 0.6)."""
    return (x1 - 0.3) ** 2 + (x2 - 0.6) ** 2 + 1.0


@pytest.fixture(scope="module")
def table():
    rng = np.random.default_rng(0)
    x1, x2 = rng.uniform(0, 1, 30), rng.uniform(0, 1, 30)
    return {"x1": x1, "x2": x2, "y": bowl(x1, x2)}


@pytest.fixture(scope="module")
def gp(table):
    return surrogate.fit(table, "y")


def test_gp_fit_says_what_it_is(gp, table):
    assert gp.model == "gp (matern52)" and gp.response == "y" and gp.factors == ["x1", "x2"]
    assert repr(gp) == "Surrogate('gp (matern52)' of 'y' on ['x1', 'x2'])"
    for (lo, hi), name in zip(gp.ranges, gp.factors):
        assert lo == table[name].min() and hi == table[name].max()
    info = gp.info
    # 80 / 20: 24 rows trained on, 6 kept to test (1-based row numbers).
    assert (info["n_train"], info["n_test"], info["n_all"]) == (24, 6, 30)
    assert sorted(info["train_rows"] + info["test_rows"]) == list(range(1, 31))
    for key in ["r2_train", "r2_test", "r2_all", "rmse_train", "rmse_test", "rmse_all", "mae_train", "mae_test",
                "mae_all"]:
        assert np.isfinite(info[key])
    assert info["r2_test"] > 0.999 and info["rmse_test"] < 0.01
    assert info["mae_all"] <= info["rmse_all"]
    assert set(info["details"]["length_scales"]) == {"x1", "x2"} and info["details"]["kernel"] == "matern52"


def test_gp_interpolates_its_training_rows_with_near_zero_variance(gp, table):
    x = np.column_stack([table["x1"], table["x2"]])
    mean, var = gp.predict(x)
    assert mean.shape == var.shape == (30,) and mean.dtype == np.float64
    train = np.array(gp.info["train_rows"]) - 1
    test = np.array(gp.info["test_rows"]) - 1
    np.testing.assert_allclose(mean[train], table["y"][train], atol=1e-5)
    assert np.all(var[train] >= -1e-12) and var[train].max() < 1e-6
    # The rows it did not see: still close (a smooth function), with some variance.
    np.testing.assert_allclose(mean[test], table["y"][test], atol=0.01)
    assert var[test].max() > 10 * np.median(var[train])
    # The metrics are these predictions' errors.
    rmse_test = float(np.sqrt(np.mean((mean[test] - table["y"][test]) ** 2)))
    assert gp.info["rmse_test"] == pytest.approx(rmse_test, rel=1e-6)


def test_gp_variance_grows_away_from_the_data(gp):
    near, var_near = gp.predict([[0.3, 0.6]])
    assert near[0] == pytest.approx(1.0, abs=1e-3)
    _, var_far = gp.predict([[2.0, 2.0]])
    _, var_farther = gp.predict([[4.0, 4.0]])
    assert var_far[0] > 1e3 * var_near[0] and var_farther[0] > var_far[0]


def test_predict_takes_arrays_dicts_and_frames(gp):
    m1, v1 = gp.predict(np.array([[0.3, 0.6], [0.5, 0.5]]))
    m2, v2 = gp.predict({"x2": [0.6, 0.5], "x1": [0.3, 0.5]})  # columns by name, in any order
    np.testing.assert_array_equal(m1, m2)
    np.testing.assert_array_equal(v1, v2)
    m3, _ = gp.predict([0.3, 0.6])  # one row
    assert m3.shape == (1,) and m3[0] == m1[0]
    pd = pytest.importorskip("pandas", reason="DataFrame rows need pandas")
    m4, _ = gp.predict(pd.DataFrame({"x2": [0.6, 0.5], "x1": [0.3, 0.5], "other": [9, 9]}))
    np.testing.assert_array_equal(m1, m4)
    with pytest.raises(demcal.InputError, match=r"x\[0\]: 3 values, expected 2 \(one per factor: x1, x2\)"):
        gp.predict([[1, 2, 3]])


def test_kernels_and_networks(table):
    se = surrogate.fit(table, "y", kernel="squared_exponential")
    assert se.model == "gp (squared_exponential)"
    assert surrogate.fit(table, "y", kernel="rbf").model == "gp (squared_exponential)"
    assert se.info["r2_test"] > 0.99
    for model in ["bp", "ga-bp"]:
        net = surrogate.fit(table, "y", model=model)
        mean, var = net.predict([[0.3, 0.6]])
        assert net.info["r2_all"] > 0.99 and mean[0] == pytest.approx(1.0, abs=0.05)
        assert var[0] >= 0  # the ensemble's spread
    # Seeded: the same seed fits the same network.
    a = surrogate.fit(table, "y", model="bp", seed=5).predict([[0.2, 0.2]])
    b = surrogate.fit(table, "y", model="bp", seed=5).predict([[0.2, 0.2]])
    assert a[0][0] == b[0][0]


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(kernel="bogus"), ['kernel: expected matern52 or squared_exponential, got "bogus"']),
        (dict(model="svm"), ["svm"]),
        (dict(train_fraction=1.0), ["train_fraction=1: expected a share between 0 and 1"]),
        (dict(factors=["x1", "zz"]), ["'zz' not found"]),
    ],
)
def test_bad_fits_are_input_errors(table, kwargs, words):
    with pytest.raises(demcal.InputError) as e:
        surrogate.fit(table, "y", **kwargs)
    for w in words:
        assert w in str(e.value)


def test_optimize_finds_the_known_minimum(table):
    out = surrogate.optimize(table, "y")
    assert out["goal"] == "minimize" and out["model"] == "gp (matern52)"
    assert out["solution"]["x1"] == pytest.approx(0.3, abs=0.01)
    assert out["solution"]["x2"] == pytest.approx(0.6, abs=0.01)
    assert out["predicted"] == pytest.approx(1.0, abs=1e-3)
    assert out["r2_test"] > 0.999


def test_optimize_reaches_a_target_and_maximises_at_a_corner(table, gp):
    out = surrogate.optimize(table, "y", "target=1.1")
    assert out["predicted"] == pytest.approx(1.1, abs=1e-3) and out["target_reached"] is True
    # The prediction is the model's at the solution.
    m, _ = gp.predict(out["solution"])
    assert m[0] == pytest.approx(out["predicted"], abs=1e-9)
    x = out["solution"]
    assert bowl(x["x1"], x["x2"]) == pytest.approx(1.1, abs=0.01)
    top = surrogate.optimize(table, "y", "maximize")["solution"]
    # The farthest corner of the data's box from (0.3, 0.6): x1 high, x2 low.
    assert top["x1"] == pytest.approx(gp.ranges[0][1], abs=1e-6)
    assert top["x2"] == pytest.approx(gp.ranges[1][0], abs=1e-6)


def test_optimize_the_error_of_a_response(table):
    # err is the relative error (%) of y against a lab value of 1.1; the response is modelled.
    t = dict(table)
    t["err"] = np.abs(t["y"] - 1.1) / 1.1 * 100
    out = surrogate.optimize(t, "err", target_of="y", value=1.1)
    assert out["predicted"] == pytest.approx(0.0, abs=0.1)
    x = out["solution"]
    assert bowl(x["x1"], x["x2"]) == pytest.approx(1.1, abs=0.01)
    with pytest.raises(demcal.InputError, match="target_of and value go together"):
        surrogate.optimize(t, "err", target_of="y")


def test_optimize_is_the_cli_json(demcal_binary):
    args = ["surrogate", "optimize", str(CCD), "--response", "angle_deg", "--factors", "D,E,G", "--model", "gp",
            "--goal", "target=38.65", "--json"]
    cli = subprocess.run([str(demcal_binary), *args], capture_output=True, text=True, check=True)
    assert surrogate.optimize(CCD, "angle_deg", "target=38.65", factors=["D", "E", "G"]) == json.loads(cli.stdout)
