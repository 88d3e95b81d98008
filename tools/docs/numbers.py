#!/usr/bin/env python3
"""The numbers the docs quote, taken from the binary rather than typed in.

Runs the examples the docs quote (copies of examples/quickstart, -bayesopt and -smc in a scratch
folder), reads their numbers from each study's report/summary.json, results.csv and the CLI's
output, and writes them into the docs between markers (--write), or lists every number that
differs (--check, which CI runs). Python 3 standard library only.

Markers (every file under version control that holds one is processed):

  <!-- n:KEY -->VALUE<!-- /n -->       Markdown, inline or spanning lines (a whole fenced block
                                       of CLI output sits between two such lines). Renders as
                                       VALUE alone.
  {n:KEY}VALUE{/n}                     TOML files (example headers): comment-safe.
  <!-- n:set NAME=KEY NAME@2=KEY -->   Markdown, on the line before a fenced block: in that
                                       block the value of the first (@2: second) line
                                       `NAME = value` becomes KEY's. `file=F` names the block,
                                       so that a KEY can run it (the tutorial's scene).

A KEY is one line of VALUES below. A number is a string formatted as the docs print it. A run
time is a Time: an example's CPU time over 2 cores (what it takes on 2 free cores; its wall time
beside other work can be several times that), written rounded ("about 35 s") and not checked:
--check only notes a time off by more than a factor of two, and --write leaves a time within that
factor as it is. A quoted block of CLI output is checked with its times masked (TIME_FIELDS).

To quote another number: one line in VALUES (`c.qs.summary` is the quickstart's summary.json,
`c.qs.rows` its results.csv, `c.qs.out` what `demcal run` printed; `c.bo`, `c.smc` the others),
and its marker where the docs print it. Formats: sig, fixed, p_value, words, and interval for a
value with its uncertainty interval, "0.115 (0.104 to 0.127)".
"""

import argparse
import csv
import difflib
import json
import re
import resource
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# The examples run, by the short name their keys start with (and their scratch folder's name,
# which the quoted CLI output shows: "report: qs/report/index.html").
EXAMPLES = {
    "qs": "quickstart",
    "bo": "quickstart-bayesopt",
    "smc": "quickstart-smc",
}

# Times inside quoted CLI output: rewritten by --write, not compared by --check.
TIME_FIELDS = [
    r"ran for \d+ s",
    r"wall_s=[0-9.]+",
    r"particle_steps_per_s=[0-9.e+-]+",
]


class Time:
    """A measured run time (s), written rounded ("about 35 s"); compared only within a factor of
    two, and then only to note it."""

    def __init__(self, seconds):
        self.seconds = seconds

    def __str__(self):
        s = self.seconds
        if s < 100:
            return f"about {max(5, round(s / 5) * 5):.0f} s"
        if s < 600:
            return f"about {round(s / 10) * 10:.0f} s"
        return f"about {round(s / 60):.0f} min"

    def agrees(self, text):
        m = re.search(r"(\d+(?:\.\d+)?)\s*(s|min)\b", text)
        if not m:
            return False
        doc = float(m.group(1)) * (60 if m.group(2) == "min" else 1)
        return self.seconds / 2 <= doc <= self.seconds * 2


# --- formats: as the CLI and the report print them ------------------------------------------


def sig(x, n=4):
    """n significant digits, as the report prints them (0.4973, 18.48, 14.02)."""
    if x == 0:
        return "0"
    digits = max(0, n - 1 - int(f"{abs(x):e}".split("e")[1]))
    return f"{x:.{digits}f}"


def fixed(x, d):
    return f"{x:.{d}f}"


def p_value(p):
    """Design-Expert's p: "< 0.0001" below it, else four decimals."""
    return "< 0.0001" if p < 1e-4 else f"{p:.4f}"


def interval(value, low, high, fmt=sig):
    """A value with its interval, "0.115 (0.110 to 0.121)": for the calibrated values' and the
    validation's uncertainty intervals, e.g. (with the summary's field for it)
      "qs.calibrated.rolling_friction.interval": lambda c: interval(*c.qs.interval("rolling_friction")),
    """
    return f"{fmt(value)} ({fmt(low)} to {fmt(high)})"


def rounded_interval(summary, name):
    """A calibrated value as the binary rounds it with its 95 % interval, the ends to the same
    decimal place: "0.115 (0.104 to 0.127)"."""
    u = summary["uncertainty"]["parameters"][name]
    value = u["rounded"]
    decimals = len(value.split(".")[1]) if "." in value else 0
    low, high = u["interval_95"]
    return f"{value} ({low:.{decimals}f} to {high:.{decimals}f})"


def words(names):
    """parameter names as prose: "static friction and rolling friction"."""
    names = [n.replace("_", " ") for n in names]
    if len(names) <= 1:
        return "".join(names)
    return ", ".join(names[:-1]) + " and " + names[-1]


def terms(names):
    """model terms as the report names them: `a*b`, `a^2`."""
    names = [f"`{n}`" for n in names]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def verdict(p, alpha=0.05):
    return "significant" if p < alpha else "not significant"


# --- one example's run ------------------------------------------------------------------------


class Run:
    """An example study run in the scratch folder: its summary, results and output."""

    def __init__(self, work, short, demcal):
        self.short, self.dir, self.demcal = short, work / short, demcal
        times = work / "times.json"
        known = json.loads(times.read_text()) if times.exists() else {}
        cmd = [demcal, "run", f"{short}/study.toml", "--jobs", "2"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = subprocess.run(cmd, cwd=work, capture_output=True, text=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if out.returncode != 0:
            sys.exit(f"{' '.join(cmd)} failed ({out.returncode}):\n{out.stderr[-3000:]}")
        # The time on 2 cores is the run's CPU time over 2 (`--jobs 2` keeps both busy): what
        # it takes on 2 free cores, where the wall time on a shared machine is anything from
        # that to several times it. A study run before (--work reused) only rewrote its
        # report: the first time is kept.
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        if short not in known:
            known[short] = cpu / 2
            times.write_text(json.dumps(known))
        self.wall = Time(known[short])
        # The quoted output's own time says the same.
        self.out = re.sub(r"ran for \d+ s", f"ran for {known[short]:.0f} s", out.stdout)
        report = self.dir / "report"
        self.summary = json.loads((report / "summary.json").read_text())
        with open(report / "results.csv", newline="") as f:
            self.rows = list(csv.DictReader(f))

    def stage(self, kind):
        return next(s for s in self.summary["stages"] if s["kind"] == kind)

    def rows_of(self, kind):
        return [r for r in self.rows if r["stage_kind"] == kind]

    def response(self, row):
        return float(row[self.summary["target"]["response"]])

    def calibrated(self, name, fmt=lambda x: fixed(x, 4)):
        return fmt(self.summary["calibrated"][name])


class Context:
    """What the keys read: the examples' runs (made on first use) and commands of the binary."""

    def __init__(self, work, demcal):
        self.work, self.demcal = work, demcal
        self.runs = {}
        self.blocks = {}  # fenced blocks named by `n:set file=...`
        self.cache = {}
        self.fresh_times = False

    def __getattr__(self, short):
        if short not in EXAMPLES:
            raise AttributeError(short)
        if short not in self.runs:
            print(f"running examples/{EXAMPLES[short]} ...", file=sys.stderr, flush=True)
            self.runs[short] = Run(self.work, short, self.demcal)
        return self.runs[short]

    def demcal_out(self, args, cwd=None, fails=False):
        """stdout and stderr of `demcal ARGS` (run in the scratch folder); `fails`: it must
        fail (a quoted error message)."""
        key = ("cmd", tuple(args), cwd)
        if key not in self.cache:
            out = subprocess.run(
                [self.demcal, *args], cwd=cwd or self.work, capture_output=True, text=True
            )
            if (out.returncode != 0) != fails:
                sys.exit(f"demcal {' '.join(args)} exited with {out.returncode}:\n{out.stderr[-3000:]}")
            self.cache[key] = (out.stdout, out.stderr)
        return self.cache[key]


# --- what the quickstart's numbers are made of ------------------------------------------------


def qs_test(c):
    """`demcal test repose.toml` in the quickstart's folder: its summary line."""
    out, _ = c.demcal_out(["test", "repose.toml"], cwd=c.qs.dir)
    return out.splitlines()[0]


def qs_test_value(c, field):
    return re.search(rf"\b{field}=(\S+)", qs_test(c)).group(1)


def qs_rsm_commands(c):
    """The two commands that hand the rsm stage's runs to `demcal doe analyze` (ranges: the
    steepest path's neighbours of its best step), as the tutorial prints them."""
    s = c.qs.summary
    names = [p["name"] for p in s["parameters"]]
    best = c.qs.stage("steepest")["best_step"]
    path = c.qs.rows_of("steepest")
    factors = [
        n for n in names if len({r[n] for r in c.qs.rows_of("rsm")}) > 1
    ]
    ranges = ",".join(
        f"{n}:{float(path[best - 2][n]):g}:{float(path[best][n]):g}" for n in factors
    )
    header = list(c.qs.rows[0].keys())
    cols = [header.index(n) + 1 for n in factors + [s["target"]["response"]]]
    awk = (
        "awk -F, 'NR == 1 || $2 == \"rsm\" { print "
        + ' "," '.join(f"${k}" for k in cols)
        + " }' report/results.csv > rsm.csv"
    )
    analyze = (
        f"demcal doe analyze rsm.csv --response {s['target']['response']} "
        f"--factors {ranges} --model quadratic"
    )
    return awk, analyze


def qs_full_model(c):
    """The rsm stage's full quadratic model, as `demcal doe analyze` fits it (the report shows
    it beside the reduced one, which is the one summary.json keeps)."""
    if "full_model" not in c.cache:
        awk, analyze = qs_rsm_commands(c)
        subprocess.run(["sh", "-c", awk], cwd=c.qs.dir, check=True)
        out, _ = c.demcal_out([*analyze.split()[1:], "--json"], cwd=c.qs.dir)
        start = 0 if out.startswith("{") else out.index("\n{") + 1
        c.cache["full_model"] = json.loads(out[start:])
    return c.cache["full_model"]


def qs_reduced(c):
    return c.qs.stage("rsm")["model"]


def qs_equation(c):
    """The reduced model in actual units, "angle = a + b × x − c × x²"."""
    coef = qs_reduced(c)["coefficients_actual"]
    text = f"angle = {sig(coef['Intercept'])}"
    for name, v in coef.items():
        if name == "Intercept":
            continue
        term = name.replace("^2", "²").replace("*", " × ")  # as the report writes it
        text += f" {'+' if v >= 0 else '−'} {sig(abs(v))} × {term}"
    return text


def qs_screening_verdicts(c):
    """Which parameters the screening found significant, with their p values."""
    terms = c.qs.stage("screening")["model"]["terms"]
    yes = [f"{words([t['name']])} (p {p_value(t['p'])})" for t in terms if t["p"] < 0.05]
    no = [f"{words([t['name']])} (p {p_value(t['p'])})" for t in terms if t["p"] >= 0.05]
    text = f"{words(yes)} {'is' if len(yes) == 1 else 'are'} significant"
    if no:
        text += f", {words(no)} {'is' if len(no) == 1 else 'are'} not"
    return text


def qs_held(c):
    """The parameters held after screening, with the values they are held at."""
    held = [p for p in c.qs.summary["parameters"] if p["status"] == "held"]
    return words([f"{p['name']} at {c.qs.summary['calibrated'][p['name']]:g}" for p in held])


def qs_centre_spread(c):
    """The spread of the rsm stage's centre points (the runs at its most repeated point)."""
    rows = c.qs.rows_of("rsm")
    names = [p["name"] for p in c.qs.summary["parameters"]]
    point = lambda r: tuple(r[n] for n in names)
    counts = {}
    for r in rows:
        counts[point(r)] = counts.get(point(r), 0) + 1
    centre = max(counts, key=counts.get)
    ys = [c.qs.response(r) for r in rows if point(r) == centre]
    return f"{fixed(min(ys), 1)} to {fixed(max(ys), 1)}", counts[centre]


def status_error(c, name, old, new):
    """The error `demcal status study.toml` prints for the quickstart's study with `old`
    replaced by `new` (in a folder of its own, beside the quickstart's test)."""
    d = c.work / f"error-{name}"
    d.mkdir(exist_ok=True)
    shutil.copy(ROOT / "examples/quickstart/repose.toml", d)
    study = (ROOT / "examples/quickstart/study.toml").read_text()
    assert old in study, f"{old} is not in examples/quickstart/study.toml"
    (d / "study.toml").write_text(study.replace(old, new, 1))
    _, err = c.demcal_out(["status", "study.toml"], cwd=d, fails=True)
    return err.strip()


def relative_error_block(c):
    mean = fixed(c.qs.summary["validation_mean"], 2)
    lab = sig(c.qs.summary["target"]["value"])
    out, _ = c.demcal_out(["lab", "relative-error", "--simulated", mean, "--lab", lab])
    return f"demcal lab relative-error --simulated {mean} --lab {lab}\n# {out.strip()}"


def heap_scene_output(c):
    """`demcal simulate` of the tutorial's own scene block: its first and last lines."""
    scene = c.work / "heap_scene.toml"
    scene.write_text(c.blocks["heap_scene.toml"])
    out, err = c.demcal_out(["simulate", "heap_scene.toml", "--threads", "2"])
    first = err.splitlines()[0]
    return f"{first}\n...\n{out.strip()}"


def fenced(lang, text):
    return f"\n```{lang}\n{text}\n```\n"


# --- every number the docs quote: one line each ----------------------------------------------

VALUES = {
    # the quickstart (examples/quickstart): its run
    "qs.runs_total": lambda c: str(c.qs.summary["runs_total"]),
    "qs.runs_failed": lambda c: str(c.qs.summary["runs_failed"]),
    "qs.wall": lambda c: c.qs.wall,
    "qs.run_output": lambda c: fenced("text", c.qs.out.rstrip()),
    # its test run once
    "qs.test_output": lambda c: fenced("sh", f"demcal test repose.toml\n# {qs_test(c)}"),
    "qs.test.angle": lambda c: qs_test_value(c, "angle_deg"),
    # the lab value and the validation
    "qs.lab.value": lambda c: sig(c.qs.summary["target"]["value"]),
    "qs.lab.std": lambda c: sig(c.qs.summary["target"]["std"]),
    "qs.lab.replicates": lambda c: str(len(c.qs.summary["target"]["replicates"])),
    "qs.validation.mean": lambda c: sig(c.qs.summary["validation_mean"]),
    "qs.validation.std": lambda c: sig(c.qs.summary["validation_std"]),
    "qs.validation.runs": lambda c: str(c.qs.summary["validation_runs"]),
    "qs.validation.error": lambda c: fixed(c.qs.summary["relative_error_percent"], 2),
    "qs.validation.values": lambda c: ", ".join(
        fixed(c.qs.response(r), 2) for r in c.qs.rows_of("validate")
    ),
    "qs.relative_error_block": lambda c: fenced("sh", relative_error_block(c)),
    # what `demcal status` says of a study with a mistake
    "qs.error.range": lambda c: fenced(
        "text", status_error(c, "range", "min = 0.2\nmax = 0.6", "min = 0.2\nmax = 1.6")
    ),
    "qs.error.stage_key": lambda c: fenced(
        "text",
        status_error(c, "key", '"rsm"', '{ stage = "rsm", desing = "ccd" }'),
    ),
    # screening
    "qs.screening.verdicts": qs_screening_verdicts,
    "qs.screening.curvature": lambda c: (
        lambda p: f"curvature is {verdict(p)} (p {p_value(p)})"
    )(c.qs.stage("screening")["model"]["curvature"]["p"]),
    "qs.screening.selected": lambda c: words(c.qs.stage("screening")["selected"]),
    "qs.screening.held": qs_held,
    "qs.screening.pure_error_df": lambda c: str(
        c.qs.stage("screening")["model"]["pure_error"]["df"]
    ),
    # steepest path
    "qs.steepest.best_step": lambda c: str(c.qs.stage("steepest")["best_step"]),
    "qs.steepest.best_point": lambda c: words(
        [
            f"{n} {float(c.qs.rows_of('steepest')[c.qs.stage('steepest')['best_step'] - 1][n]):g}"
            for n in c.qs.stage("screening")["selected"]
        ]
    ),
    "qs.steepest.best_response": lambda c: fixed(
        c.qs.response(c.qs.rows_of("steepest")[c.qs.stage("steepest")["best_step"] - 1]), 2
    ),
    "qs.steepest.best_error": lambda c: fixed(
        float(
            c.qs.rows_of("steepest")[c.qs.stage("steepest")["best_step"] - 1][
                "relative_error_percent"
            ]
        ),
        2,
    ),
    # response surface: the design, the full model (doe analyze), the reduced one (summary)
    "qs.rsm.alpha": lambda c: re.search(r"alpha = ([0-9.]+)", c.qs.stage("rsm")["title"]).group(1),
    "qs.rsm.runs": lambda c: str(c.qs.stage("rsm")["runs"]),
    "qs.rsm.centre_points": lambda c: str(qs_centre_spread(c)[1]),
    "qs.rsm.centre_spread": lambda c: qs_centre_spread(c)[0],
    "qs.rsm.commands": lambda c: fenced("sh", "\n".join(qs_rsm_commands(c))),
    "qs.rsm.full.verdicts": lambda c: (
        lambda m: f"the full model is {verdict(m['model']['p'])} (p {p_value(m['model']['p'])}), "
        f"lack of fit is {verdict(m['lack_of_fit']['p'])} (p {p_value(m['lack_of_fit']['p'])})"
    )(qs_full_model(c)),
    "qs.rsm.full.r2": lambda c: fixed(qs_full_model(c)["r2"], 4),
    "qs.rsm.full.adj_r2": lambda c: fixed(qs_full_model(c)["adj_r2"], 4),
    "qs.rsm.full.pred_r2": lambda c: fixed(qs_full_model(c)["pred_r2"], 4),
    "qs.rsm.full.adeq": lambda c: sig(qs_full_model(c)["adeq_precision"]),
    "qs.rsm.reduced.terms": lambda c: terms([t["name"] for t in qs_reduced(c)["terms"]]),
    "qs.rsm.reduced.removed": lambda c: ", ".join(
        f"`{t['name']}` (p {p_value(t['p'])})" for t in qs_reduced(c)["removed_terms"]
    ),
    "qs.rsm.reduced.r2": lambda c: fixed(qs_reduced(c)["r2"], 4),
    "qs.rsm.reduced.pred_r2": lambda c: fixed(qs_reduced(c)["pred_r2"], 4),
    "qs.rsm.reduced.adeq": lambda c: sig(qs_reduced(c)["adeq_precision"]),
    "qs.rsm.reduced.equation": qs_equation,
    # optimisation and the calibrated values
    "qs.optimize.solutions": lambda c: str(len(c.qs.stage("optimize")["solutions"])),
    "qs.optimize.predicted": lambda c: sig(c.qs.stage("optimize")["solutions"][0]["responses"][0]),
    "qs.calibrated.static_friction": lambda c: c.qs.calibrated("static_friction"),
    "qs.calibrated.rolling_friction": lambda c: c.qs.calibrated("rolling_friction"),
    "qs.calibrated.restitution": lambda c: c.qs.calibrated("restitution", "{:g}".format),
    "qs.calibrated.wall_friction": lambda c: c.qs.calibrated("wall_friction", "{:g}".format),
    # each calibrated value's 95 % interval, to the digits the binary rounds it to
    "qs.interval.rolling_friction": lambda c: rounded_interval(c.qs.summary, "rolling_friction"),
    "qs.validation.interval": lambda c: " to ".join(sig(x) for x in c.qs.summary["validation"]["mean_interval_95"]),
    "qs.validation.compatible": lambda c: c.qs.summary["validation"]["statement"].split(":")[0],
    "qs.undetermined": lambda c: words(
        [p["name"] for p in c.qs.summary["parameters"] if p["status"] == "undetermined"]
    ),
    # the tutorial's own scene of the calibrated beads, simulated
    "qs.heap_scene_output": lambda c: fenced("text", heap_scene_output(c)),
    # the Bayesian optimisation and sequential Monte Carlo quickstarts
    "bo.runs_total": lambda c: str(c.bo.summary["runs_total"]),
    "bo.wall": lambda c: c.bo.wall,
    "smc.runs_total": lambda c: str(c.smc.summary["runs_total"]),
    "smc.wall": lambda c: c.smc.wall,
}

MARKER = re.compile(
    r"(?P<open><!-- n:(?P<key>[\w.]+) -->)(?P<value>.*?)(?P<close><!-- /n -->)"
    r"|(?P<topen>\{n:(?P<tkey>[\w.]+)\})(?P<tvalue>.*?)(?P<tclose>\{/n\})",
    re.S,
)
SET = re.compile(r"^<!-- n:set (?P<pairs>[^>]*?) -->\n(?P<fence>```[^\n]*\n)(?P<body>.*?\n)```", re.M | re.S)


def masked(text):
    for pattern in TIME_FIELDS:
        text = re.sub(pattern, "<time>", text)
    return text


def value_of(c, key):
    if key not in VALUES:
        sys.exit(f"unknown number {key}: add a line for it to VALUES in {__file__}")
    if key not in c.cache:
        c.cache[key] = VALUES[key](c)
    return c.cache[key]


def apply_sets(c, path, text, faults):
    """`n:set` blocks: each NAME's value in the fenced block after the marker."""

    def one(m):
        body = m.group("body")
        for pair in m.group("pairs").split():
            name, key = pair.split("=", 1)
            if name == "file":
                continue
            name, _, nth = name.partition("@")
            lines = body.split("\n")
            hits = [i for i, l in enumerate(lines) if re.match(rf"\s*{name}\s*=", l)]
            k = int(nth or 1) - 1
            if k >= len(hits):
                faults.append(f"{path}: n:set {name}: no line {name} = ... in the block")
                continue
            line = lines[hits[k]]
            old = re.match(rf"(\s*{name}\s*=\s*)(\S+)", line)
            new = value_of(c, key)
            if old.group(2) != str(new):
                faults.append(f"{path}: {key} ({name}): the docs say {old.group(2)}, the binary gives {new}")
            # The comment after the value keeps its column.
            rest = line[old.end() :]
            pad = len(rest) - len(rest.lstrip(" "))
            if rest.strip():
                pad = max(1, pad + len(old.group(2)) - len(str(new)))
            lines[hits[k]] = old.group(1) + str(new) + " " * pad + rest.lstrip(" ")
            body = "\n".join(lines)
        for pair in m.group("pairs").split():
            if pair.startswith("file="):
                c.blocks[pair[5:]] = body
        return m.group(0)[: m.start("body") - m.start()] + body + "```"

    return SET.sub(one, text)


def short(text):
    text = str(text).strip()
    return text if len(text) < 80 and "\n" not in text else "(a block)"


def process(c, path, text, faults, notes):
    text = apply_sets(c, path, text, faults)

    def one(m):
        toml = m.group("tkey") is not None
        key = m.group("tkey") if toml else m.group("key")
        old = m.group("tvalue") if toml else m.group("value")
        new = value_of(c, key)
        if isinstance(new, Time):
            # Times are not checked: beside other work on 2 cores a study's times vary more
            # than twofold. One within a factor of two is left as written (--times: rewritten).
            if new.agrees(old) and not c.fresh_times:
                new = old
            elif not new.agrees(old):
                notes.append(f"{path}: {key}: the docs say {short(old)}, this run took {new}")
        elif masked(old) == masked(str(new)):
            if not c.fresh_times:
                new = old  # the same but for its times: as written, so --write does not churn
        else:
            if short(old) == short(new) == "(a block)":
                diff = [
                    line
                    for line in difflib.unified_diff(
                        masked(old).splitlines(), masked(str(new)).splitlines(), lineterm="", n=0
                    )
                    if line[:1] in "+-" and line[:3] not in ("---", "+++")
                ]
                shown = "\n      ".join(diff[:8])
                faults.append(f"{path}: {key}: the quoted output differs (- docs, + binary):\n      {shown}")
            else:
                faults.append(f"{path}: {key}: the docs say {short(old)}, the binary gives {short(new)}")
        if toml:
            return f"{m.group('topen')}{new}{m.group('tclose')}"
        return f"{m.group('open')}{new}{m.group('close')}"

    return MARKER.sub(one, text)


def marked_files():
    """The Markdown and TOML files under version control that hold a marker (without git, every
    one outside target/)."""
    try:
        names = subprocess.run(
            ["git", "ls-files", "*.md", "*.toml"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        names = [
            str(p.relative_to(ROOT))
            for ext in ("*.md", "*.toml")
            for p in ROOT.rglob(ext)
            if "target" not in p.relative_to(ROOT).parts
        ]
    return sorted(n for n in names if re.search(r"<!-- n:|\{n:", (ROOT / n).read_text()))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true", help="rewrite the numbers in the docs")
    mode.add_argument("--check", action="store_true", help="fail listing every number that differs")
    ap.add_argument("--demcal", required=True, help="the demcal binary")
    ap.add_argument(
        "--times",
        action="store_true",
        help="with --write: write the run times measured now even where the docs' are within a "
        "factor of two of them",
    )
    ap.add_argument(
        "--work",
        help="scratch folder; kept, and reused by the next call (its studies only rewrite their "
        "reports, and the times first measured are kept)",
    )
    args = ap.parse_args()
    demcal = str(Path(args.demcal).resolve())
    if args.work:
        work = Path(args.work).resolve()
        work.mkdir(parents=True, exist_ok=True)
    else:
        work = Path(tempfile.mkdtemp(prefix="demcal-docs-"))
    try:
        for short, name in EXAMPLES.items():
            if not (work / short).exists():
                shutil.copytree(
                    ROOT / "examples" / name,
                    work / short,
                    ignore=shutil.ignore_patterns("study.db*", "*.runs", "report"),
                )
        c = Context(work, demcal)
        c.fresh_times = args.write and args.times
        faults, notes = [], []
        for name in marked_files():
            path = ROOT / name
            text = path.read_text()
            new = process(c, name, text, faults, notes)
            if args.write and new != text:
                path.write_text(new)
                print(f"rewrote {name}")
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)
    for n in notes:
        print(f"time (not checked): {n}", file=sys.stderr)
    if args.check and faults:
        print(f"{len(faults)} numbers in the docs differ from what the binary gives:", file=sys.stderr)
        for f in faults:
            print(f"  {f}", file=sys.stderr)
        print("rewrite them with: bash tools/docs/numbers.sh --write", file=sys.stderr)
        return 1
    if args.check:
        print("every number in the docs is what the binary gives")
    return 0


if __name__ == "__main__":
    sys.exit(main())
