"""demcal.Study on the function-test study of the Rust suite (BOWL, crates/study/tests/studies.rs):
what `demcal run`, `status` and `report` do, the stored runs as rows, resuming, and the errors."""

from __future__ import annotations

import json
import shutil

import pytest

import demcal

from conftest import BOWL, bowl_value, write_study

STAGES = {1: ("screening", 13), 2: ("steepest", 5), 3: ("rsm", 13), 5: ("validate", 3)}


@pytest.fixture(scope="module")
def bowl(tmp_path_factory):
    """BOWL run once with 2 jobs: (the Study, what run returned, its stderr)."""
    path = write_study(tmp_path_factory.mktemp("bowl"))
    study = demcal.Study.load(path)
    assert study.results(frame=False) == []
    before = study.status()
    out = study.run(jobs=2)
    return study, out, before


def test_load_reads_the_study(tmp_path):
    s = demcal.Study.load(write_study(tmp_path))
    assert s.name == "bowl" and s.seed == 3
    assert s.plan == ["screening", "steepest", "rsm", "optimize", "validate"]
    assert [(p["name"], p["min"], p["max"], p["paths"]) for p in s.parameters] == [
        ("a", 0.4, 1.2, ["function.variables.a"]),
        ("b", 0.1, 0.9, ["function.variables.b"]),
        ("c", 0.0, 1.0, ["function.variables.c"]),
        ("d", 0.0, 1.0, ["function.variables.d"]),
    ]
    assert s.tests == ["function"] and s.response == "value"
    assert s.store == str(tmp_path / "study.db") and s.report_dir == str(tmp_path / "report")
    # Nothing has run: no rows, no report.
    assert s.results(frame=False) == [] and len(s.results(frame=True)) == 0
    with pytest.raises(FileNotFoundError, match="no report yet"):
        s.summary()
    assert s.status().startswith("bowl: not started")


def test_run_calibrates_and_says_so(bowl):
    study, out, before = bowl
    assert "not started" in before and "5 stages planned" in before
    assert "state: complete" in out
    assert "1. screening  13 runs: 10 done, 3 failed, 0 pending" in out
    assert "3. rsm        13 runs: 13 done, 0 failed, 0 pending" in out
    assert "calibrated: a = 0.60, b = 0.30, c = 0.5000, d = 0.5000" in out
    # status replays what run printed, without running.
    status = study.status()
    assert "13 runs: 10 done, 3 failed, 0 pending" in status and "state: complete" in status


def test_results_as_rows(bowl):
    study, _, _ = bowl
    rows = study.results(frame=False)
    assert isinstance(rows, list) and len(rows) == 13 + 5 + 13 + 3
    assert list(rows[0]) == ["stage", "stage_kind", "run", "seed", "status", "response", "a", "b", "c", "d",
                             "wall_s", "error", "error_kind", "outputs"]
    for stage, (kind, n) in STAGES.items():
        mine = [r for r in rows if r["stage"] == stage]
        assert len(mine) == n and {r["stage_kind"] for r in mine} == {kind}
        assert sorted(r["run"] for r in mine) == list(range(1, n + 1))
    # Every run has its own seed.
    assert len({r["seed"] for r in rows}) == len(rows)
    failed = [r for r in rows if r["status"] == "failed"]
    assert len(failed) == 3
    for r in failed:
        assert r["stage"] == 1 and r["error_kind"] == "diverged" and "fail_when" in r["error"]
        assert r["c"] + r["d"] > 1.7 and r["response"] is None
    done = [r for r in rows if r["status"] == "done"]
    assert len(done) == 31
    for r in done:
        # The response is the formula at the run's parameters plus noise of s.d. 0.02.
        assert r["response"] == pytest.approx(bowl_value(r["a"], r["b"], r["c"], r["d"]), abs=0.1)
        assert r["outputs"]["exact"] == pytest.approx(bowl_value(r["a"], r["b"], r["c"], r["d"]), abs=1e-9)
        assert r["response"] == pytest.approx(r["outputs"]["exact"] + r["outputs"]["noise"], abs=1e-12)
        assert r["error"] is None and r["error_kind"] is None and r["wall_s"] >= 0


def test_results_as_a_data_frame(bowl):
    pd = pytest.importorskip("pandas", reason="results() as a DataFrame needs pandas")
    study, _, _ = bowl
    df = study.results()
    assert isinstance(df, pd.DataFrame) and df.shape == (34, 14)
    assert df.groupby("stage").size().to_dict() == {s: n for s, (_, n) in STAGES.items()}
    assert (df["status"] == "done").sum() == 31
    assert df.equals(study.results(frame=True))
    rows = study.results(frame=False)
    assert df["response"].dropna().tolist() == [r["response"] for r in rows if r["response"] is not None]
    assert df.loc[df["stage_kind"] == "validate", "response"].mean() == pytest.approx(30.0, abs=0.1)


def test_summary_has_the_calibrated_values(bowl):
    study, _, _ = bowl
    s = study.summary()
    cal = s["calibrated"]
    assert cal["a"] == pytest.approx(0.6, abs=0.02) and cal["b"] == pytest.approx(0.3, abs=0.02)
    assert cal["c"] == 0.5 and cal["d"] == 0.5
    assert s["stages"][0]["selected"] == ["a", "b"]
    assert s["runs_total"] == 34 and s["runs_failed"] == 3 and s["validation_runs"] == 3
    assert s["relative_error_percent"] < 0.3
    assert [p["status"] for p in s["parameters"]] == ["calibrated", "calibrated", "held", "held"]


def test_report_writes_a_folder(bowl, tmp_path):
    study, _, _ = bowl
    folder = study.report(out=tmp_path / "elsewhere")
    assert isinstance(folder, str) and folder == str(tmp_path / "elsewhere")
    html = (tmp_path / "elsewhere" / "index.html").read_text()
    for part in ["Pareto chart", "Steepest path", "Reduced model", "Validation"]:
        assert part in html
    written = json.loads((tmp_path / "elsewhere" / "summary.json").read_text())
    assert written["calibrated"] == study.summary()["calibrated"]
    csv_lines = (tmp_path / "elsewhere" / "results.csv").read_text().splitlines()
    assert len(csv_lines) == 1 + 34
    # Without out: the study's own report folder.
    assert study.report() == study.report_dir


def test_a_second_run_reuses_every_stored_run(bowl, capfd):
    study, out, _ = bowl
    rows = study.results(frame=False)
    capfd.readouterr()
    again = study.run(jobs=2)
    err = capfd.readouterr().err
    # The same text but for its last line, this call's wall time ("ran for 0 s; report: ...").
    assert again.splitlines()[:-1] == out.splitlines()[:-1]
    assert again.splitlines()[-1].startswith("ran for ")
    assert "runs to make" not in err  # nothing was simulated
    assert study.results(frame=False) == rows  # the same runs, wall times included


def test_jobs_do_not_change_the_numbers(bowl, tmp_path):
    study, _, _ = bowl
    one = demcal.Study.load(write_study(tmp_path))
    one.run(jobs=1)
    assert [(r["seed"], r["response"]) for r in one.results(frame=False)] == [
        (r["seed"], r["response"]) for r in study.results(frame=False)]


def test_a_study_that_stops_raises_study_error(tmp_path):
    s = demcal.Study.load(write_study(tmp_path, BOWL.replace('fail_when = "c + d - 1.7"', 'fail_when = "1"')))
    with pytest.raises(demcal.StudyError, match=r"0 of 13 runs finished \(13 failed.*needs at least 6"):
        s.run(jobs=2)
    # The failures are stored with why.
    rows = s.results(frame=False)
    assert len(rows) == 13 and {r["error_kind"] for r in rows} == {"diverged"}
    assert "state: stopped" in s.status()


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("seed = 3", "seed = 3\nbogus = 1", ["bogus: unknown key"]),
        ('path = "function.variables.a"', 'path = "function.variables.zz"',
         ["parameter[0].path", "function.variables.zz", "there: a, b, c, d"]),
        ("min = 0.4", "min = 1.4", ["parameter[0].min: expected min < max", "min = 1.4 and max = 1.2"]),
        ('test = "function"', 'test = "nonsense"', ['unknown test "nonsense"']),
    ],
)
def test_a_broken_study_is_an_input_error_naming_the_key(tmp_path, old, new, words):
    assert old in BOWL
    path = write_study(tmp_path, BOWL.replace(old, new, 1))
    with pytest.raises(demcal.InputError) as e:
        demcal.Study.load(path)
    assert str(e.value).startswith(str(path))
    for w in words:
        assert w in str(e.value)


def test_bad_arguments_and_missing_files_are_input_errors(tmp_path):
    with pytest.raises(demcal.InputError, match="cannot read: No such file"):
        demcal.Study.load(tmp_path / "missing.toml")
    s = demcal.Study.load(write_study(tmp_path))
    with pytest.raises(demcal.InputError, match="jobs=0: expected a whole number >= 1"):
        s.run(jobs=0)


def test_a_changed_study_is_noticed_and_restart_starts_over(bowl, tmp_path):
    study, _, _ = bowl
    shutil.copytree(study.path.rsplit("/", 1)[0], tmp_path / "copy")
    path = tmp_path / "copy" / "study.toml"
    path.write_text(BOWL.replace("min = 0.4\nmax = 1.2", "min = 0.45\nmax = 1.2"))
    s = demcal.Study.load(path)
    with pytest.raises(demcal.DemcalError, match=r"no longer match.*a = 0\.4000.*0\.4500.*--restart"):
        s.run(jobs=2)
    with pytest.raises(demcal.InputError, match="no longer match"):
        s.status()
    assert "state: complete" in s.run(jobs=2, restart=True)
    assert [p.name for p in (tmp_path / "copy").iterdir() if ".db.old-" in p.name] != []
    assert min(r["a"] for r in s.results(frame=False)) >= 0.45 - 1e-12


def test_a_lock_held_elsewhere_raises_study_locked_error(tmp_path):
    s = demcal.Study.load(write_study(tmp_path))
    # A lock file being written this moment by another runner.
    (tmp_path / "study.db.lock").write_text("")
    with pytest.raises(demcal.StudyLockedError, match=r"lock file .*study\.db\.lock.*try again"):
        s.run()
    assert issubclass(demcal.StudyLockedError, demcal.StudyError)


def test_retry_failed_runs_the_failed_runs_again(bowl, tmp_path, capfd):
    study, _, _ = bowl
    shutil.copytree(study.path.rsplit("/", 1)[0], tmp_path / "copy")
    s = demcal.Study.load(tmp_path / "copy" / "study.toml")
    before = s.results(frame=False)
    capfd.readouterr()
    s.run(jobs=2, retry_failed=True)
    err = capfd.readouterr().err
    assert "3 failed run(s) will run again" in err
    assert "stage 1/5 screening: 3 runs to make (10 stored)" in err
    after = s.results(frame=False)
    # The same points failed again (fail_when is deterministic); every other run was kept.
    assert len(after) == 34
    for a, b in zip(before, after):
        if a["status"] == "done":
            assert a == b
        else:
            assert (b["status"], b["a"], b["b"], b["c"], b["d"]) == ("failed", a["a"], a["b"], a["c"], a["d"])
