"""demcal.Test: reading a test file or a dict, running it at a parameter point, its responses and
curves, and the errors (`InputError` before anything runs, a `RunError` subclass per failure
kind, or a `Result` with `ok` False when `check=False`)."""

from __future__ import annotations

import csv
import json
import math
import time
try:
    import tomllib  # Python 3.11+
except ModuleNotFoundError:  # 3.9 and 3.10: the test extra installs tomli
    import tomli as tomllib

import numpy as np
import pytest

import demcal
from demcal.errors import BY_KIND, for_kind

from conftest import QUICKSTART_TEST, function_table

MU_R = "interaction[bead,bead].rolling_friction"


# --- reading -------------------------------------------------------------------------------


def test_load_reads_the_file_as_a_dict(quickstart):
    assert quickstart.kind == "angle_of_repose"
    assert quickstart.response_names == ["angle_of_repose_deg", "angle_std_deg", "heap_height_m", "heap_radius_m"]
    assert quickstart.warnings == []
    assert quickstart.name == str(QUICKSTART_TEST)
    assert quickstart.folder == str(QUICKSTART_TEST.parent)
    with open(QUICKSTART_TEST, "rb") as f:
        assert quickstart.to_dict() == tomllib.load(f)


def test_to_dict_is_a_copy_and_from_dict_round_trips(quickstart):
    d = quickstart.to_dict()
    d["interaction"][0]["rolling_friction"] = 0.25
    d["angle_of_repose"]["fill"]["count"] = 7
    # The Test is unchanged...
    assert quickstart.to_dict()["interaction"][0]["rolling_friction"] == 0.1
    assert quickstart.to_dict()["angle_of_repose"]["fill"]["count"] == 500
    # ... and a new one is made from the changed dict.
    t = demcal.Test.from_dict(d, name="changed")
    assert t.kind == "angle_of_repose" and t.name == "changed" and t.folder == "."
    assert t.to_dict()["interaction"][0]["rolling_friction"] == 0.25
    # The dict given to from_dict is copied too.
    d["interaction"][0]["rolling_friction"] = 0.3
    assert t.to_dict()["interaction"][0]["rolling_friction"] == 0.25


def test_a_friction_alias_gives_a_warning(quickstart):
    d = quickstart.to_dict()
    d["interaction"][0]["dynamic_friction"] = d["interaction"][0].pop("rolling_friction")
    t = demcal.Test.from_dict(d)
    assert len(t.warnings) == 1
    assert "interaction[0].dynamic_friction" in t.warnings[0] and "rolling friction" in t.warnings[0]


# --- running a DEM test --------------------------------------------------------------------


@pytest.fixture(scope="module")
def repose_runs(quickstart):
    """The quickstart heap at seed 2: rolling friction 0.02 (twice, on 2 threads and on 1) and
    0.2, with each call's wall time."""
    out = {}
    for key, mu_r, threads in [("low", 0.02, 2), ("low_again", 0.02, 1), ("high", 0.2, 2)]:
        t0 = time.perf_counter()
        r = quickstart.run({MU_R: mu_r}, seed=2, threads=threads)
        out[key] = (r, time.perf_counter() - t0)
    return out


def test_a_run_gives_its_responses(repose_runs, quickstart):
    r, elapsed = repose_runs["low"]
    assert r.ok and r.error is None and r.error_kind is None
    assert list(r.responses) == sorted(quickstart.response_names)
    assert all(isinstance(v, float) for v in r.responses.values())
    assert r["angle_of_repose_deg"] == r.responses["angle_of_repose_deg"]
    assert 0 < r["angle_of_repose_deg"] < 45
    assert 0 < r["heap_height_m"] < 0.09 and r["heap_radius_m"] > 0.0225
    # The outcome is what `demcal test --json` prints; the summary its one line.
    assert r.outcome["particles"] == 500
    assert r.summary.startswith("angle_of_repose: angle_deg=") and "particles=500" in r.summary
    assert f"angle_deg={r['angle_of_repose_deg']:.2f}" in r.summary
    assert r.params == {MU_R: 0.02} and r.seed == 2
    assert r.curves == {}
    # wall_s is the simulation's own time: within the call's.
    assert 0.2 < r.wall_s <= elapsed
    assert elapsed - r.wall_s < 0.5


def test_the_same_seed_gives_identical_responses_on_any_thread_count(repose_runs):
    a, _ = repose_runs["low"]
    b, _ = repose_runs["low_again"]
    assert a.responses == b.responses
    assert a.outcome["flank_angles_deg"] == b.outcome["flank_angles_deg"] and len(a.outcome["flank_angles_deg"]) > 2


def test_more_rolling_friction_makes_a_steeper_heap(repose_runs):
    low, _ = repose_runs["low"]
    high, _ = repose_runs["high"]
    # Measured: 5.5 deg at 0.02 and 25.9 deg at 0.2 (seed 2).
    assert high["angle_of_repose_deg"] > low["angle_of_repose_deg"] + 10
    assert high["heap_radius_m"] < low["heap_radius_m"]
    assert high["heap_height_m"] > low["heap_height_m"]


# --- curves --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def pulled(tension, tmp_path_factory):
    out = tmp_path_factory.mktemp("pulled")
    return tension.run(threads=2, out=out), out


def test_a_mechanical_test_gives_its_curve_as_numpy_arrays(tension, pulled):
    r, _ = pulled
    assert tension.kind == "tension"
    assert tension.response_names == [
        "peak_force_n", "mean_force_n", "stiffness_n_per_m", "displacement_at_peak_m", "bonds_broken",
        "force_displacement"]
    assert set(r.curves) == {"force_displacement"}
    assert set(r.responses) == set(tension.response_names) - {"force_displacement"}
    c = r.curves["force_displacement"]
    assert isinstance(c.x, np.ndarray) and isinstance(c.y, np.ndarray)
    assert c.x.dtype == np.float64 and c.y.dtype == np.float64
    assert c.x.shape == c.y.shape == (len(c),) and len(c) > 20
    assert (c.x_name, c.x_unit, c.y_name, c.y_unit) == ("displacement", "m", "force", "N")
    assert c.x[0] == 0.0 and np.all(np.diff(c.x) > 0)
    # The curve's peak is the peak force response, at the displacement of the peak.
    assert c.peak == pytest.approx(r["peak_force_n"], rel=1e-12)
    assert c.x[np.argmax(c.y)] == pytest.approx(r["displacement_at_peak_m"], rel=1e-9)
    # The bar broke: the test stopped once the force fell below 20 % of the peak.
    assert c.y[-1] < 0.2 * c.peak
    assert r["bonds_broken"] >= 1 and r.outcome["quasi_static"] is True


def test_out_writes_the_curve_and_result_files(pulled):
    r, out = pulled
    names = {p.name for p in out.iterdir()}
    assert {"result.json", "force_displacement.csv", "force_displacement.svg", "bond_breakage.csv"} <= names
    assert r.outcome["curve_csv"] == str(out / "force_displacement.csv")
    with open(out / "force_displacement.csv", newline="") as f:
        rows = list(csv.reader(f))
    data = np.array([[float(v) for v in row[:2]] for row in rows[1:]])
    c = r.curves["force_displacement"]
    assert data.shape[0] == len(c)
    np.testing.assert_allclose(data[:, 0], c.x, rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(data[:, 1], c.y, rtol=1e-5, atol=1e-9)
    # result.json is the outcome (`demcal test --json`).
    assert json.loads((out / "result.json").read_text()) == r.outcome
    assert r.outcome["peak_force_n"] == r["peak_force_n"]


def test_without_out_nothing_is_written(tension, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = tension.run({"tension.max_displacement": 0.0005}, threads=2)
    assert r.outcome["curve_csv"] is None and list(tmp_path.iterdir()) == []


def test_stronger_bonds_raise_the_peak_force_and_quantities_take_units(tension, pulled):
    base, _ = pulled
    strong = tension.run({"bond[stalk,stalk].critical_normal_stress": 4e5}, threads=2)
    assert strong["peak_force_n"] > 1.3 * base["peak_force_n"]
    # A quantity with its unit is the same number in SI: identical results.
    same = tension.run({"material[stalk].shear_modulus": "151.1 MPa"}, threads=2)
    assert same.responses == base.responses


def test_the_function_test_gives_its_formula_and_curve():
    t = demcal.Test.from_dict({
        "test": "function",
        "function": {"expression": "2*k", "variables": {"k": 1.5},
                     "curve": {"expression": "k*x/(1 + 100*x)", "x_min": 0.0, "x_max": 0.01, "points": 5}},
    })
    assert t.kind == "function" and t.response_names == ["value", "exact", "force_displacement"]
    r = t.run({"function.variables.k": 3})  # an int is a number too
    assert r.responses == {"value": 6.0, "exact": 6.0}
    c = r.curves["force_displacement"]
    np.testing.assert_array_equal(c.x, np.linspace(0.0, 0.01, 5))
    np.testing.assert_allclose(c.y, 3 * c.x / (1 + 100 * c.x), rtol=1e-15, atol=0)
    assert r.outcome["seed"] == 1  # no seed in the file: 1
    # Noise is seeded: the same seed gives the same draw, another seed another.
    noisy = demcal.Test.from_dict({"test": "function", "function": {"expression": "10", "noise": 0.5}})
    a, b, c2 = noisy.run(seed=7), noisy.run(seed=7), noisy.run(seed=8)
    assert a["value"] == b["value"] != c2["value"]
    assert a["exact"] == 10.0 and a["value"] == pytest.approx(10.0 + a.outcome["noise"], abs=1e-12)


# --- input errors: InputError, naming the key, before anything runs -------------------------


@pytest.mark.parametrize(
    "params, words",
    [
        ({"interaction[bead,bead].rolling_frction": 0.1},
         ['params["interaction[bead,bead].rolling_frction"]', "rolling_frction", "rolling_friction"]),
        ({"interaction[bead,glass].rolling_friction": 0.1},
         ['params["interaction[bead,glass].rolling_friction"]', "no interaction matches [bead,glass]"]),
        ({MU_R: [0.1]}, [f'params["{MU_R}"]', "expected a number or a quantity"]),
        ({MU_R: True}, [f'params["{MU_R}"]', "got a bool"]),
        ({MU_R: float("nan")}, [f'params["{MU_R}"]', "expected a finite number"]),
        ({MU_R: "abc"}, ["interaction[0].rolling_friction", '"abc"']),
        ({"material[bead].density": "29 MPa"}, ["material[0].density", "29 MPa", "expected a density"]),
        ({3: 0.1}, ["params", "parameter paths (str)"]),
    ],
)
def test_a_bad_parameter_is_an_input_error_naming_it(quickstart, params, words):
    t0 = time.perf_counter()
    with pytest.raises(demcal.InputError) as e:
        quickstart.run(params)
    assert time.perf_counter() - t0 < 0.5  # refused before anything ran
    msg = str(e.value)
    assert msg.startswith(str(QUICKSTART_TEST) + ": ")
    for w in words:
        assert w in msg, msg
    assert isinstance(e.value, demcal.DemcalError) and not isinstance(e.value, demcal.RunError)


def test_an_unknown_file_is_an_input_error(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(demcal.InputError, match=f"^{missing}: cannot read: No such file"):
        demcal.Test.load(missing)
    bad = tmp_path / "bad.toml"
    bad.write_text('test = "angle_of_repose"\n[angle_of_repose\n')
    with pytest.raises(demcal.InputError, match=f"^{bad}: "):
        demcal.Test.load(bad)


@pytest.mark.parametrize(
    "table, words",
    [
        ({"test": "nonsense"}, ['unknown test "nonsense"', "angle_of_repose", "function"]),
        ({"test": "function", "function": {"expression": "a", "variables": {"a": 1}, "bogus": 1}},
         ["function.bogus", "unknown field `bogus`"]),
        ({"test": "function", "function": {"expression": "a", "variables": {"a": None}}}, ["no None"]),
    ],
)
def test_a_bad_test_dict_is_an_input_error_naming_the_key(table, words):
    with pytest.raises(demcal.InputError) as e:
        demcal.Test.from_dict(table, name="mine")
    assert str(e.value).startswith("mine: ")
    for w in words:
        assert w in str(e.value)


def test_bad_run_arguments_are_input_errors(tension, tmp_path):
    with pytest.raises(demcal.InputError, match="threads=0: expected a whole number >= 1"):
        tension.run(threads=0)
    with pytest.raises(demcal.InputError, match="seed=-1: expected a whole number >= 0"):
        tension.run(seed=-1)
    with pytest.raises(demcal.InputError, match="threads=5000: expected 1 to 4096"):
        tension.run(threads=5000)
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    with pytest.raises(demcal.InputError, match=f"^{a_file}: cannot make the folder"):
        tension.run(out=a_file)


# --- runs that fail: a RunError subclass per kind, or ok False with check=False -------------


def test_refused_settings_raise_settings_error(quickstart):
    params = {"interaction[bead,bead].restitution": 1.5}
    with pytest.raises(demcal.SettingsError) as e:
        quickstart.run(params)
    assert "interaction[0].restitution: expected a value in (0, 1], got 1.5" in str(e.value)
    assert e.value.kind == "bad_settings"
    assert e.value.result.ok is False and e.value.result.params == params
    r = quickstart.run(params, check=False)
    assert (r.ok, r.error_kind, r.responses, r.curves, r.outcome) == (False, "bad_settings", {}, {}, None)
    assert r.error == str(e.value)
    with pytest.raises(demcal.SettingsError):
        r.raise_for_error()


def test_a_failed_simulation_raises_diverged_error():
    t = demcal.Test.from_dict({"test": "function",
                               "function": {"expression": "a", "variables": {"a": 1.0}, "fail_when": "a - 0.5"}})
    with pytest.raises(demcal.DivergedError, match='fail_when "a - 0.5" holds') as e:
        t.run()
    assert e.value.kind == "diverged" and isinstance(e.value, demcal.RunError)
    r = t.run(check=False)
    assert (r.ok, r.error_kind) == (False, "diverged")
    # Where fail_when does not hold, the same test runs.
    assert t.run({"function.variables.a": 0.25}).responses == {"value": 0.25, "exact": 0.25}


def test_a_measurement_that_cannot_be_made_raises_measurement_error():
    t = demcal.Test.from_dict(function_table("1/a", a=0.0))
    with pytest.raises(demcal.MeasurementError, match=r"the response is not finite \(inf\)"):
        t.run()
    assert t.run(check=False).error_kind == "measurement_failed"


def test_a_pull_too_fast_raises_not_quasi_static_error_with_its_numbers(tension):
    with pytest.raises(demcal.NotQuasiStaticError) as e:
        tension.run({"tension.speed": 1.0}, threads=2)
    assert "not quasi-static" in str(e.value) and "lower tension.speed" in str(e.value)
    # The run measured everything: the result keeps it, for a look at the curve.
    r = e.value.result
    assert r.ok is False and r.error_kind == "not_quasi_static"
    assert r["peak_force_n"] > 0 and len(r.curves["force_displacement"]) > 2
    assert r.outcome["quasi_static"] is False and r.outcome["max_kinetic_to_work_ratio"] > 0.05


def test_every_failure_kind_has_its_exception():
    assert BY_KIND == {
        "bad_settings": demcal.SettingsError,
        "diverged": demcal.DivergedError,
        "escaped": demcal.EscapedError,
        "measurement_failed": demcal.MeasurementError,
        "not_quasi_static": demcal.NotQuasiStaticError,
        "output_failed": demcal.OutputError,
    }
    for cls in BY_KIND.values():
        assert issubclass(cls, demcal.RunError) and issubclass(cls, demcal.DemcalError)
    assert for_kind("interrupted") is demcal.RunError
    for cls in (demcal.InputError, demcal.RunError, demcal.StudyError):
        assert issubclass(cls, demcal.DemcalError)
    assert issubclass(demcal.StudyLockedError, demcal.StudyError)
    assert not issubclass(demcal.InputError, demcal.RunError)


def test_errors_survive_pickling():
    """Exceptions cross process boundaries (multiprocessing, concurrent.futures) by pickle."""
    import pickle

    for cls in (demcal.InputError, demcal.DivergedError, demcal.StudyLockedError):
        e = pickle.loads(pickle.dumps(cls("x.toml: key: why")))
        assert type(e) is cls and str(e) == "x.toml: key: why"
        assert cls.__module__ == "demcal"


def test_wall_s_is_measured_for_a_slow_formula():
    t = demcal.Test.from_dict({"test": "function", "function": {"expression": "1", "duration_s": 0.3}})
    t0 = time.perf_counter()
    r = t.run()
    elapsed = time.perf_counter() - t0
    assert 0.3 <= r.wall_s <= elapsed < 0.3 + 0.5
    assert r.outcome["wall_s"] == pytest.approx(0.3, abs=0.05)
    assert math.isfinite(r["value"])


def test_whole_numbers_stay_whole(quickstart):
    """A count is a parameter (an int, numpy's too); a float is refused where a count is read."""
    import numpy as np

    a = quickstart.run({"angle_of_repose.fill.count": 150}, threads=2)
    b = quickstart.run({"angle_of_repose.fill.count": np.int64(150)}, threads=2)
    assert a.responses == b.responses
    assert a.outcome["particles"] == 150
    with pytest.raises(demcal.InputError, match="floating point"):
        quickstart.run({"angle_of_repose.fill.count": 150.0})
