# %% [markdown]
# # Calibrating the quickstart angle of repose with Optuna
#
# The quickstart (`examples/quickstart/`) calibrates a 500-bead lifted-cylinder heap against a
# lab angle of repose through demcal's Design-Expert-style plan (screening, steepest path,
# response surface, desirability, validation). This script does the same calibration the way an
# Optuna user would: the same four parameters over the same ranges, read from the study file, a
# seeded TPE sampler minimising the relative error of the simulated angle against the lab value,
# and then the check every calibration needs, the best point rerun with new seeds.
#
# demcal runs in-process: each trial is one `demcal.Test.run` call (no files, no subprocess).
#
#     python python/examples/optuna_quickstart.py              # 60 trials, a few minutes on 2 cores
#     python python/examples/optuna_quickstart.py --trials 100
#     python python/examples/optuna_quickstart.py --quick      # 4 trials, for the tests
#
# It runs from any folder (paths are taken from this file's location) and as a notebook: each
# `# %%` is a cell (VS Code, Spyder, or Jupyter through jupytext).

# %%
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

try:
    import tomllib  # Python 3.11+
except ModuleNotFoundError:  # Python 3.9 and 3.10
    import tomli as tomllib

import optuna

import demcal

HERE = Path(__file__).resolve().parent
STUDY_FILE = HERE.parents[1] / "examples" / "quickstart" / "study.toml"

# %% [markdown]
# ## The calibration problem, from the study file
#
# `demcal.Study.load` checks the study and gives each parameter's name, range and the test-file
# paths it sets (`interaction[bead,bead].rolling_friction`, ...); those paths are exactly the keys
# `Test.run` takes. The lab value (the mean of the five replicates) and the test file are read
# from the same TOML file, so this script always calibrates what the study calibrates.


# %%
def load_problem(study_file: Path = STUDY_FILE) -> dict:
    """The quickstart's test, parameters, response and lab value, as the study file gives them."""
    study = demcal.Study.load(study_file)
    with open(study_file, "rb") as f:
        raw = tomllib.load(f)
    replicates = [float(v) for v in raw["target"]["replicates"]]
    return {
        "test": demcal.Test.load(study_file.parent / raw["test"]),
        "parameters": study.parameters,  # name, display_name, min, max, paths
        "response": study.response,  # "angle_of_repose_deg"
        "replicates": replicates,
        "lab": statistics.mean(replicates),  # 18.48 deg
        "lab_sd": statistics.stdev(replicates),
        "seed": study.seed,
    }


def test_inputs(parameters: list, values: dict) -> dict:
    """Parameter values by name -> the test's keys (a parameter may set several paths)."""
    return {path: values[p["name"]] for p in parameters for path in p["paths"]}


# %% [markdown]
# ## One simulation per trial
#
# Every trial uses the study's packing seed, so any trial can be rerun exactly and a seeded run
# of this script repeats. That does not make the angle a smooth function of the parameters: a
# heap is chaotic, and a small change of a parameter changes how the beads fall about as much
# as a new seed does, and new seeds at one point spread by about 1-2 deg (SD; see README.md)
# where the lab's replicates spread by 0.5. So the best trial is partly the luckiest one, and
# the validation below reruns it with other seeds to measure the error a user would really see.
#
# A 500-bead heap does not run faster on 2 threads than on 1 (measured: 3.8 s either way), so
# the script runs `--jobs` trials at once, one thread each (Optuna's ask-and-tell interface;
# `Test.run` releases the GIL, so Python threads are enough). Their order of completion does not
# matter: results are told back in the order they were asked, so a seeded run is repeatable.


# %%
def simulate(test: demcal.Test, inputs: dict, seed: int, response: str) -> float:
    """The simulated response (the angle of repose, deg) at `inputs`; raises demcal.RunError if
    the simulation gave no result."""
    return test.run(inputs, seed=seed, threads=1).responses[response]


def calibrate(problem: dict, n_trials: int, jobs: int, sampler_seed: int, log=print) -> optuna.Study:
    """Runs `n_trials` Optuna trials, `jobs` at a time, minimising |angle - lab| / lab."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # this script prints its own lines
    # TPE, seeded; its first 10 trials are random (Optuna's n_startup_trials) before it models
    # the good and bad regions. constant_liar (Optuna's default) keeps two trials asked at once
    # from landing on the same point.
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=sampler_seed))
    params, lab, response = problem["parameters"], problem["lab"], problem["response"]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        while len(study.trials) < n_trials:
            batch = [study.ask() for _ in range(min(jobs, n_trials - len(study.trials)))]
            values = [{p["name"]: t.suggest_float(p["name"], p["min"], p["max"]) for p in params} for t in batch]
            futures = [pool.submit(simulate, problem["test"], test_inputs(params, v), problem["seed"], response)
                       for v in values]
            for trial, v, fut in zip(batch, values, futures):
                try:
                    angle = fut.result()
                except demcal.RunError as e:  # diverged, escaped, ...: a failed trial, not a crash
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    log(f"trial {trial.number:3d} failed ({e.__class__.__name__}: {e})")
                    continue
                error = abs(angle - lab) / lab
                trial.set_user_attr("angle_deg", angle)
                study.tell(trial, error)
                shown = "  ".join(f"{k} {x:.4f}" for k, x in v.items())
                log(f"trial {trial.number:3d}  {shown}  angle {angle:6.2f} deg  error {100 * error:6.2f} %")
    return study


# %% [markdown]
# ## Validation: the best point with new seeds
#
# The best trial's error is optimistic: out of many trials on one packing, the best is partly the
# luckiest. Three new packings (seeds the trials never used) give the angle a user should expect
# at the calibrated point, its spread, and the honest relative error of their mean (what demcal's
# own `validate` stage reports).


# %%
def validate(problem: dict, values: dict, seeds: list, jobs: int) -> dict:
    inputs = test_inputs(problem["parameters"], values)
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        angles = list(pool.map(lambda s: simulate(problem["test"], inputs, s, problem["response"]), seeds))
    mean = statistics.mean(angles)
    return {
        "seeds": seeds,
        "angles_deg": angles,
        "mean_deg": mean,
        "sd_deg": statistics.stdev(angles) if len(angles) > 1 else float("nan"),
        "rel_error": abs(mean - problem["lab"]) / problem["lab"],
    }


# %%
def main(argv=None) -> dict:
    if argv is None and "ipykernel" in sys.modules:
        argv = []  # run as notebook cells: the defaults, not the kernel's own arguments
    ap = argparse.ArgumentParser(description="Calibrate the demcal quickstart angle of repose with Optuna.")
    ap.add_argument("--trials", type=int, default=60, help="Optuna trials (default 60)")
    ap.add_argument("--quick", action="store_true", help="4 trials: a smoke test, not a calibration")
    ap.add_argument("--jobs", type=int, default=2, help="simulations at once, one thread each (default 2)")
    ap.add_argument("--sampler-seed", type=int, default=1, help="TPE sampler seed (default 1)")
    ap.add_argument("--json", type=Path, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    n_trials = 4 if args.quick else args.trials

    problem = load_problem()
    print(f"{STUDY_FILE}: lab {problem['response']} = {problem['lab']:.2f} deg "
          f"(SD {problem['lab_sd']:.2f} over {len(problem['replicates'])} replicates)")
    for p in problem["parameters"]:
        print(f"  {p['display_name']}: {p['min']} .. {p['max']}  ({', '.join(p['paths'])})")

    t0 = time.perf_counter()
    study = calibrate(problem, n_trials, args.jobs, args.sampler_seed)
    wall_opt = time.perf_counter() - t0
    done = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    best = study.best_trial
    print(f"\n{len(done)} of {len(study.trials)} trials finished in {wall_opt:.0f} s")
    print(f"best: trial {best.number}, angle {best.user_attrs['angle_deg']:.2f} deg, "
          f"error {100 * best.value:.2f} % (seed {problem['seed']})")
    for name, v in best.params.items():
        print(f"  {name} = {v:.4f}")

    # Seeds the trials never used (they all ran on the study's seed).
    seeds = [problem["seed"] + i for i in (1, 2, 3)]
    t1 = time.perf_counter()
    val = validate(problem, best.params, seeds, args.jobs)
    wall_val = time.perf_counter() - t1
    print(f"\nvalidation, seeds {seeds}: " + ", ".join(f"{a:.2f}" for a in val["angles_deg"]) + " deg")
    print(f"  mean {val['mean_deg']:.2f} deg, SD {val['sd_deg']:.2f} deg, "
          f"error {100 * val['rel_error']:.2f} % against the lab's {problem['lab']:.2f} deg")
    wall = time.perf_counter() - t0
    n_sims = len(study.trials) + len(seeds)
    print(f"\n{n_sims} simulations, {wall:.0f} s wall ({args.jobs} at a time)")

    numbers = {
        "lab_deg": problem["lab"],
        "trials": len(study.trials),
        "trials_failed": len(study.trials) - len(done),
        "best_trial": best.number,
        "best_params": best.params,
        "best_angle_deg": best.user_attrs["angle_deg"],
        "best_rel_error": best.value,
        "validation": val,
        "simulations": n_sims,
        "wall_s": wall,
        "wall_optimisation_s": wall_opt,
        "wall_validation_s": wall_val,
    }
    if args.json:
        args.json.write_text(json.dumps(numbers, indent=2))
    return numbers


if __name__ == "__main__":
    main()
