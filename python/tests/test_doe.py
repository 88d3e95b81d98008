"""demcal.doe: designs (sizes, coded and actual columns), Design-Expert's ANOVA against the numbers
the Rust suite asserts (crates/doe/tests/reference.rs: the published silage analyses of
docs/calibration.md; statsmodels.rs: statsmodels' type III ANOVA), the same JSON as
`demcal doe analyze --json`, and the desirability optimisation."""

from __future__ import annotations

import csv
import json
import math
import subprocess

import pytest

import demcal
from demcal import doe

from conftest import REPO

DATA = REPO / "crates" / "doe" / "tests" / "data"
PB = DATA / "silage-repose-pb.csv"
CCD = DATA / "silage-repose-ccd.csv"


def printed(got: float, text: str) -> None:
    """`got` rounds to the printed digits of `text` (half a unit in the last place)."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    assert abs(got - float(text)) <= 0.5 * 10.0 ** -decimals + 1e-12, f"{got} is not {text}"


def row(fit: doe.Analysis, source: str) -> dict:
    return next(r for r in fit.anova if r["source"] == source)


def read_columns(path) -> dict:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


# --- designs --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kind, factors, options, runs, points",
    [
        ("ccd", "mu_s:0.2:0.8,mu_r:0.05:0.25", {"center_points": 5}, 13, {"factorial": 4, "axial": 4, "center": 5}),
        ("ccd", 3, {}, 20, {"factorial": 8, "axial": 6, "center": 6}),
        ("ccd", 5, {}, 32, {"factorial": 16, "axial": 10, "center": 6}),  # half-fraction cube
        ("plackett-burman", 11, {}, 12, {"factorial": 12}),
        ("pb", 7, {}, 12, {"factorial": 12}),
        ("pb", 7, {"center_points": 1}, 13, {"factorial": 12, "center": 1}),
        ("factorial", 3, {}, 8, {"factorial": 8}),
        ("fractional", 5, {"resolution": 3}, 8, {"factorial": 8}),
        ("fractional", 5, {"resolution": 5}, 16, {"factorial": 16}),
        ("box-behnken", 3, {}, 17, {"edge": 12, "center": 5}),
        ("bbd", 3, {"center_points": 3}, 15, {"edge": 12, "center": 3}),
        ("lhs", 3, {"runs": 10}, 10, {"interior": 10}),
        ("random", 2, {"runs": 7}, 7, {"interior": 7}),
    ],
)
def test_design_sizes(kind, factors, options, runs, points):
    d = doe.design(kind, factors, **options)
    assert len(d) == len(d.rows) == runs
    counts: dict = {}
    for r in d.rows:
        counts[r["point_type"]] = counts.get(r["point_type"], 0) + 1
    assert counts == points
    assert sorted(r["run_order"] for r in d.rows) == list(range(1, runs + 1))
    assert sorted(r["std_order"] for r in d.rows) == list(range(1, runs + 1))
    k = factors if isinstance(factors, int) else factors.count(",") + 1
    assert len(d.factors) == k


def test_a_rotatable_ccd_in_coded_and_actual_units():
    d = doe.design("ccd", "mu_s:0.2:0.8,mu_r:0.05:0.25", center_points=5)
    assert d.factors == ["mu_s", "mu_r"]
    assert d.summary.startswith("central composite (rotatable, alpha = 1.41421): 13 runs (5 centre points)")
    alpha = math.sqrt(2)
    for r in d.rows:
        assert list(r)[:3] == ["std_order", "run_order", "point_type"]
        if r["point_type"] == "axial":
            assert max(abs(r["mu_s"]), abs(r["mu_r"])) == pytest.approx(alpha, rel=1e-9)
        # actual = centre + coded x half the range
        assert r["mu_s_actual"] == pytest.approx(0.5 + 0.3 * r["mu_s"], abs=1e-9)
        assert r["mu_r_actual"] == pytest.approx(0.15 + 0.1 * r["mu_r"], abs=1e-9)
    assert d.actual()[0] == {"mu_s": d.rows[0]["mu_s_actual"], "mu_r": d.rows[0]["mu_r_actual"]}


def test_factor_forms_face_centred_and_log_scale():
    d = doe.design("ccd", {"mu": (0.2, 0.6), "k": (1e6, 1e8, "log")}, alpha="face", center_points=2)
    assert len(d) == 10 and d.factors == ["mu", "k"]
    for r in d.rows:
        assert max(abs(r["mu"]), abs(r["k"])) <= 1
        # log: the actual value is geometric, 1e7 at the centre.
        assert r["k_actual"] == pytest.approx(10 ** (7 + r["k"]), rel=1e-9)
    assert "k: 1000000 .. 100000000 (log)" in d.summary


def test_latin_hypercube_fills_every_stratum_once():
    d = doe.design("lhs", "a:0:1,b:10:20", runs=10, lhs="maximin", seed=4)
    for name, low, high in [("a", 0, 1), ("b", 10, 20)]:
        strata = sorted(int((r[name + "_actual"] - low) / (high - low) * 10) for r in d.rows)
        assert strata == list(range(10))


def test_the_seed_orders_the_runs_and_nothing_else():
    d1, d2 = doe.design("ccd", 2, seed=1), doe.design("ccd", 2, seed=2)
    assert [r["std_order"] for r in d1.rows] != [r["std_order"] for r in d2.rows]
    by_std = lambda d: sorted((r["std_order"], r["A"], r["B"]) for r in d.rows)  # noqa: E731
    assert by_std(d1) == by_std(d2)
    assert doe.design("ccd", 2, seed=1).rows == d1.rows


def test_a_steepest_path():
    d = doe.design("steepest", "a:0:1,b:10:20", direction=[1.0, -0.5], step=0.5)
    assert [(r["a"], r["b"]) for r in d.rows] == [(0.5 * i, -0.25 * i) for i in range(7)]
    assert d.rows[-1]["a_actual"] == pytest.approx(2.0) and d.rows[-1]["b_actual"] == pytest.approx(7.5)


def test_design_frame():
    pd = pytest.importorskip("pandas", reason="Design.frame needs pandas")
    d = doe.design("bbd", 3)
    df = d.frame()
    assert isinstance(df, pd.DataFrame) and df.shape == (17, 3 + 3 + 3)
    assert df["point_type"].value_counts().to_dict() == {"edge": 12, "center": 5}


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: doe.design("nonsense", 2), ["unknown design 'nonsense'", "plackett-burman"]),
        (lambda: doe.design("ccd", "a:1:0"), ["factor a: expected low < high"]),
    ],
)
def test_bad_designs_are_input_errors(call, words):
    with pytest.raises(demcal.InputError) as e:
        call()
    for w in words:
        assert w in str(e.value)


# --- analysis: the published reference analyses (crates/doe/tests/reference.rs) ------------


def test_plackett_burman_first_order_with_curvature():
    f = doe.analyze(PB, "angle_deg")  # two-level data: linear by default
    assert [r["source"] for r in f.anova] == ["Model", *"ABCDEFGH", "Curvature", "Residual", "Cor Total"]
    printed(row(f, "Model")["sum_sq"], "63.98")
    assert row(f, "Model")["df"] == 8
    printed(row(f, "Residual")["sum_sq"], "1.26")
    assert row(f, "Residual")["df"] == 3
    printed(row(f, "Cor Total")["sum_sq"], "65.50")
    assert row(f, "Cor Total")["df"] == 12
    for name, ss, p in [("A", "0.6674", "0.2967"), ("B", "0.1610", "0.5798"), ("C", "0.3434", "0.4327"),
                        ("D", "6.89", "0.0272"), ("E", "46.93", "0.0018"), ("F", "1.04", "0.2140"),
                        ("G", "5.24", "0.0386"), ("H", "2.72", "0.0845")]:
        printed(row(f, name)["sum_sq"], ss)
        printed(f.p(name), p)
        assert row(f, name)["mean_sq"] == pytest.approx(row(f, name)["sum_sq"], rel=1e-12)  # 1 df
        assert row(f, name)["f"] == pytest.approx(row(f, name)["mean_sq"] / row(f, "Residual")["mean_sq"], rel=1e-12)
    assert row(f, "Residual")["f"] is None and row(f, "Residual")["p"] is None
    # One centre point: curvature, but no pure error.
    assert f.p("Curvature") is not None and "Lack of Fit" not in [r["source"] for r in f.anova]
    # R² as Design-Expert gives it with a curvature row: model over model plus residual.
    model, resid = row(f, "Model")["sum_sq"], row(f, "Residual")["sum_sq"]
    assert f.r2 == pytest.approx(model / (model + resid), rel=1e-12)
    printed(f.r2, "0.9807")
    assert f.coefficients_actual is None  # coded columns only
    assert f.coefficients_coded["E"] == pytest.approx(1.9775, abs=1e-12)
    # Effects are twice the coefficients in a balanced design.
    for e in f.raw["effects"]:
        assert e["effect"] == pytest.approx(2 * f.coefficients_coded[e["name"]], abs=1e-12)
    with pytest.raises(KeyError, match="'Z': no such row"):
        f.p("Z")


def test_central_composite_full_quadratic():
    f = doe.analyze(CCD, "angle_deg", model="quadratic")
    printed(row(f, "Model")["sum_sq"], "590.10")
    assert row(f, "Model")["df"] == 9
    printed(row(f, "Residual")["sum_sq"], "39.22")
    assert row(f, "Residual")["df"] == 13
    printed(row(f, "Lack of Fit")["sum_sq"], "24.41")
    assert row(f, "Lack of Fit")["df"] == 5
    printed(f.p("Lack of Fit"), "0.1073")
    printed(row(f, "Pure Error")["sum_sq"], "14.81")
    assert row(f, "Pure Error")["df"] == 8
    printed(row(f, "Cor Total")["sum_sq"], "629.32")
    for name, ss in [("D", "199.26"), ("E", "69.59"), ("G", "258.26"), ("DE", "4.98"), ("DG", "3.91"),
                     ("EG", "7.39"), ("D^2", "14.43"), ("E^2", "2.07"), ("G^2", "30.69")]:
        printed(row(f, name)["sum_sq"], ss)
    printed(f.p("DE"), "0.2214")
    printed(f.p("D^2"), "0.0476")
    printed(f.p("G^2"), "0.0071")
    printed(f.r2, "0.9377")
    printed(f.adj_r2, "0.8945")
    printed(f.std_dev, "1.737")
    printed(f.cv_percent, "4.29")
    printed(f.mean, "40.46")
    assert "Curvature" not in [r["source"] for r in f.anova]
    assert f.pred_r2 is not None and f.pred_r2 < f.adj_r2 and f.press > 0
    assert f.adeq_precision > 4


def test_central_composite_reduced_by_backward_elimination():
    f = doe.analyze(CCD, "angle_deg", model="quadratic", reduce=True)
    assert [c["name"] for c in f.coefficients] == ["Intercept", "D", "E", "G", "D^2", "G^2"]
    printed(row(f, "Model")["sum_sq"], "571.76")
    printed(row(f, "Residual")["sum_sq"], "57.57")
    assert row(f, "Residual")["df"] == 17
    printed(row(f, "Lack of Fit")["sum_sq"], "42.76")
    assert row(f, "Lack of Fit")["df"] == 9
    printed(f.p("Lack of Fit"), "0.0996")
    for c, want in zip(f.coefficients, ["39.07", "3.82", "2.26", "4.35", "0.9505", "1.39"]):
        printed(c["estimate"], want)
    # Removed one at a time, the least significant first, each p above alpha_out = 0.10.
    removed = f.raw["removed_terms"]
    assert [t["name"] for t in removed] == ["E^2", "DG", "DE", "EG"]
    assert all(t["p"] > 0.10 for t in removed)
    # The same model as a term list fits identically.
    g = doe.analyze(CCD, "angle_deg", model="D,E,G,D^2,G^2")
    assert g.coefficients_coded == pytest.approx(f.coefficients_coded, rel=1e-12)


STATSMODELS = [
    ("bbd3.csv", "A,B,C,AB,AC,BC,A^2,B^2,C^2",
     [("A", 49.52278414, 222.5934717, 2.448175528e-05), ("B", 13.75739383, 61.83630642, 0.0005342485175),
      ("C", 1.900306317, 8.5414378, 0.03291521227), ("AB", 8.903715904, 40.02014565, 0.001454924455),
      ("AC", 0.1065999645, 0.4791422089, 0.5196352519), ("BC", 0.3460045331, 1.555210426, 0.2675981061),
      ("A^2", 18.54916364, 83.37420448, 0.0002639205935), ("B^2", 0.02413039177, 0.1084605353, 0.7552517669),
      ("C^2", 6.19779999, 27.85767886, 0.003250193531)],
     (1.112404235, 5), 0.9891157924, 0.9695242188),
    ("factorial_unbalanced.csv", "A,B,C,AB,AC,BC",
     [("A", 20.4326355, 121.3053713, 4.109536534e-06), ("B", 4.462684231, 26.4942605, 0.0008772731717),
      ("C", 5.231926181, 31.06113002, 0.0005264389463), ("AB", 0.2257192238, 1.34005984, 0.2804144302),
      ("AC", 1.918775085, 11.39146852, 0.009711538174), ("BC", 0.01813507776, 0.1076651292, 0.7512412893)],
     (1.34751728, 8), 0.9637429972, 0.9365502451),
    ("scattered4.csv", "A,B,C,D,AB,A^2,C^2",
     [("A", 6.5749183, 96.72081332, 1.633510434e-09), ("B", 2.114213715, 31.10129445, 1.319524527e-05),
      ("C", 0.4802296504, 7.064453161, 0.01437074083), ("D", 0.2114578165, 3.110665572, 0.09166569263),
      ("AB", 1.106682403, 16.27993189, 0.0005540265182), ("A^2", 1.481954075, 21.80039308, 0.0001177407069),
      ("C^2", 0.006922301389, 0.1018310175, 0.7526534879)],
     (1.495523018, 22), 0.9040996806, 0.8735859427),
]


@pytest.mark.parametrize("file, terms, rows, residual, r2, adj_r2", STATSMODELS, ids=[c[0] for c in STATSMODELS])
def test_type_three_anova_matches_statsmodels(file, terms, rows, residual, r2, adj_r2):
    f = doe.analyze(DATA / file, "y", model=terms)
    close = dict(rel=1e-8, abs=1e-15)  # statsmodels printed 10 significant digits
    assert [r["source"] for r in f.anova[1:1 + len(rows)]] == [name for name, *_ in rows]
    for name, ss, fv, p in rows:
        assert row(f, name)["sum_sq"] == pytest.approx(ss, **close)
        assert row(f, name)["f"] == pytest.approx(fv, **close)
        assert row(f, name)["p"] == pytest.approx(p, **close)
    assert row(f, "Residual")["sum_sq"] == pytest.approx(residual[0], **close)
    assert row(f, "Residual")["df"] == residual[1]
    assert f.r2 == pytest.approx(r2, **close) and f.adj_r2 == pytest.approx(adj_r2, **close)


def test_every_table_form_gives_the_same_fit():
    by_path = doe.analyze(CCD, "angle_deg", model="quadratic")
    columns = read_columns(CCD)
    by_dict = doe.analyze(columns, "angle_deg", model="quadratic")
    rows = [dict(zip(columns, vals)) for vals in zip(*columns.values())]
    by_rows = doe.analyze(rows, "angle_deg", model="quadratic")
    for other in (by_dict, by_rows):
        assert other.anova == by_path.anova and other.coefficients == by_path.coefficients
    pd = pytest.importorskip("pandas", reason="DataFrame input needs pandas")
    by_frame = doe.analyze(pd.read_csv(CCD), "angle_deg", model="quadratic")
    assert by_frame.anova == by_path.anova and by_frame.r2 == by_path.r2
    table = by_path.anova_frame()
    assert list(table.columns) == ["source", "sum_sq", "df", "mean_sq", "f", "p"] and len(table) == len(by_path.anova)


def test_actual_unit_factors_give_an_actual_equation():
    # y = 3 + 20 mu - 15 mu^2 + 2 e + 4 mu e on a CCD in actual units.
    d = doe.design("ccd", "mu:0.2:0.6,e:0.1:0.5", center_points=4, seed=3)
    cols = {"mu": [r["mu_actual"] for r in d.rows], "e": [r["e_actual"] for r in d.rows]}
    cols["y"] = [3 + 20 * m - 15 * m * m + 2 * e + 4 * m * e for m, e in zip(cols["mu"], cols["e"])]
    f = doe.analyze(cols, "y", factors="mu:0.2:0.6,e:0.1:0.5", model="quadratic")
    want = {"Intercept": 3.0, "mu": 20.0, "mu^2": -15.0, "e": 2.0, "mu*e": 4.0, "e^2": 0.0}
    for name, value in want.items():
        assert f.coefficients_actual[name] == pytest.approx(value, abs=1e-6), name
    assert f.r2 == pytest.approx(1.0, abs=1e-12)


def test_several_responses_and_plots(tmp_path):
    columns = read_columns(CCD)
    columns["double"] = [2 * y for y in columns.pop("angle_deg")]
    columns["angle_deg"] = [y / 2 for y in columns["double"]]
    single = doe.analyze(CCD, ["angle_deg"], factors="D,E,G", model="quadratic")
    assert isinstance(single, list) and len(single) == 1
    fits = doe.analyze(columns, ["angle_deg", "double"], factors="D,E,G", model="quadratic")
    assert [f.response for f in fits] == ["angle_deg", "double"]
    assert fits[0].anova == single[0].anova
    assert row(fits[1], "Model")["sum_sq"] == pytest.approx(4 * row(fits[0], "Model")["sum_sq"], rel=1e-9)
    assert fits[1].p("G") == pytest.approx(fits[0].p("G"), rel=1e-9)
    doe.analyze(CCD, "angle_deg", model="quadratic", plots=str(tmp_path / "plots"))
    svgs = sorted(p.name for p in (tmp_path / "plots").iterdir())
    assert {"contour.svg", "normal_plot.svg", "predicted_vs_actual.svg", "residuals_vs_predicted.svg"} <= set(svgs)
    assert all((tmp_path / "plots" / s).read_text().lstrip().startswith("<") for s in svgs)


def test_several_responses_with_default_factors_leave_each_other_out():
    columns = read_columns(CCD)
    columns["double"] = [2 * y for y in columns["angle_deg"]]
    fits = doe.analyze(columns, ["angle_deg", "double"], model="quadratic")
    assert [c["name"] for c in fits[0].coefficients] == [c["name"] for c in doe.analyze(CCD, "angle_deg").coefficients]


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(response="angle"), ["column 'angle' not found", "angle_deg"]),
        (dict(response="angle_deg", model="D,Q"), ["'Q' is not a factor"]),
        (dict(response="angle_deg", reduce=True, alpha_out=1.5), ["1.5: expected a number between 0 and 1"]),
    ],
)
def test_bad_analyses_are_input_errors(kwargs, words):
    with pytest.raises(demcal.InputError) as e:
        doe.analyze(CCD, **kwargs)
    for w in words:
        assert w in str(e.value)


def test_a_bad_table_is_an_error_naming_the_cell():
    with pytest.raises(demcal.InputError, match="row 4, column 'A': 'x' is not a number"):
        doe.analyze({"A": [1, -1, "x"], "y": [1, 2, 3]}, "y")
    with pytest.raises(ValueError, match="different lengths: A 2, y 3"):
        doe.analyze({"A": [1, -1], "y": [1, 2, 3]}, "y")
    with pytest.raises(TypeError, match="expected a CSV file's path"):
        doe.analyze(42, "y")


def test_analyze_json_is_the_cli_json(demcal_binary):
    for args, kwargs in [
        (["--model", "quadratic", "--reduce"], dict(model="quadratic", reduce=True)),
        ([], {}),
    ]:
        cli = subprocess.run([str(demcal_binary), "doe", "analyze", str(CCD), "--response", "angle_deg", "--json",
                              *args], capture_output=True, text=True, check=True)
        assert doe.analyze(CCD, "angle_deg", **kwargs).raw == json.loads(cli.stdout)
    cli = subprocess.run([str(demcal_binary), "doe", "analyze", str(PB), "--response", "angle_deg", "--json"],
                         capture_output=True, text=True, check=True)
    assert doe.analyze(PB, "angle_deg").raw == json.loads(cli.stdout)


# --- optimisation ---------------------------------------------------------------------------


def test_optimize_meets_a_target_inside_a_factor_range():
    out = doe.optimize(CCD, ["angle_deg:target=38.65", "D:range:lower=-0.5:upper=0.5"], factors="D,E,G",
                       model="quadratic", reduce=True, solutions=5, starts=40)
    assert out["factors"] == ["D", "E", "G"] and out["responses"] == ["angle_deg"]
    assert len(out["solutions"]) == 5
    for s in out["solutions"]:
        assert s["responses"][0] == pytest.approx(38.65, abs=1e-3)
        assert s["desirability"] > 0.999
        assert abs(s["coded"][0]) <= 0.5 + 1e-12
    # The prediction is the reduced model's at the solution.
    f = doe.analyze(CCD, "angle_deg", model="quadratic", reduce=True)
    c = f.coefficients_coded
    d, e, g = out["solutions"][0]["coded"]
    y = c["Intercept"] + c["D"] * d + c["E"] * e + c["G"] * g + c["D^2"] * d * d + c["G^2"] * g * g
    assert y == pytest.approx(out["solutions"][0]["responses"][0], abs=1e-9)


def test_optimize_maximise_goes_to_the_corner_and_goal_forms_agree():
    a = doe.optimize(CCD, "maximize:upper=60", responses=["angle_deg"], model="quadratic", reduce=True,
                     solutions=3, starts=20, seed=2)
    assert a["solutions"][0]["coded"] == pytest.approx([1.0, 1.0, 1.0], abs=1e-6)
    b = doe.optimize(CCD, {"angle_deg": "maximize:upper=60"}, model="quadratic", reduce=True, solutions=3,
                     starts=20, seed=2)
    assert b == a


def test_optimize_goals_that_do_not_say_their_responses_are_refused():
    with pytest.raises(demcal.InputError, match="names no column"):
        doe.optimize(CCD, "maximize", model="quadratic")
    with pytest.raises(demcal.InputError, match=r"responses=\[\.\.\.\]\) or which are factors"):
        doe.optimize(CCD, ["angle_deg:target=38.65", "D:range:lower=-0.5:upper=0.5"], model="quadratic")
    # Told which are responses, the same goals work.
    out = doe.optimize(CCD, ["angle_deg:target=38.65", "D:range:lower=-0.5:upper=0.5"], responses=["angle_deg"],
                       model="quadratic", solutions=2, starts=20)
    assert out["responses"] == ["angle_deg"] and out["solutions"][0]["desirability"] > 0.999


def test_bad_goals_are_input_errors():
    with pytest.raises(demcal.InputError, match="expected a goal"):
        doe.optimize(CCD, "angle_deg:best", model="quadratic")
    with pytest.raises(demcal.InputError, match="importance must be a whole number 1 to 5"):
        doe.optimize(CCD, "angle_deg:max:importance=9", model="quadratic")
