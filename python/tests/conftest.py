"""Shared set-up of the package's tests (python/tests).

Which `demcal` is tested: the pure-Python files of this checkout (python/demcal/*.py) over the
installed native module (`demcal._demcal`, built by `pip install ./python`), so that a change to
the Python half is tested without rebuilding the extension. `DEMCAL_TEST_INSTALLED=1` tests the
installed package exactly as installed. The header of the pytest run says which.

The fixtures give small inputs that run fast on 2 cores: the quickstart's 500-bead repose test
(about 3-4 s a run), a 39-sphere bonded bar pulled in tension (under 1 s, with a
force-displacement curve), the `function` test (a formula: instant), an 891-sphere settling box,
and the function-test study the Rust suite uses (crates/study/tests/studies.rs, BOWL).
"""

from __future__ import annotations

import contextlib
import importlib.machinery
import importlib.util
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional

import pytest

REPO = Path(__file__).resolve().parents[2]
SOURCE = REPO / "python" / "demcal"


def _import_demcal() -> str:
    """Imports `demcal` (the checkout's .py files over the installed native module unless told
    otherwise) and says what was imported, for the report header."""
    if "demcal" in sys.modules:
        return f"demcal from {Path(sys.modules['demcal'].__file__).parent} (imported before the tests)"
    spec = importlib.util.find_spec("demcal")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("demcal is not installed: pip install ./python (needs the Rust toolchain)")
    installed = Path(list(spec.submodule_search_locations)[0]).resolve()
    if os.environ.get("DEMCAL_TEST_INSTALLED") == "1" or installed == SOURCE.resolve():
        import demcal  # noqa: F401

        return f"demcal from {installed}"
    # The installed native module, loaded first under its own name (so that a stale one left in
    # the checkout by `maturin develop` is not picked up), then the package from the checkout,
    # whose `from . import _demcal` finds it in sys.modules.
    native = next((p for s in importlib.machinery.EXTENSION_SUFFIXES for p in installed.glob("_demcal" + s)), None)
    if native is None:
        raise RuntimeError(f"{installed}: no native module _demcal; reinstall: pip install ./python")
    loader = importlib.machinery.ExtensionFileLoader("demcal._demcal", str(native))
    native_spec = importlib.util.spec_from_file_location("demcal._demcal", native, loader=loader)
    pkg = importlib.util.spec_from_file_location("demcal", SOURCE / "__init__.py",
                                                 submodule_search_locations=[str(SOURCE)])
    assert native_spec is not None and pkg is not None and pkg.loader is not None
    try:
        sys.modules["demcal._demcal"] = importlib.util.module_from_spec(native_spec)
        loader.exec_module(sys.modules["demcal._demcal"])
        module = importlib.util.module_from_spec(pkg)
        module._demcal = sys.modules["demcal._demcal"]  # type: ignore[attr-defined]
        sys.modules["demcal"] = module
        pkg.loader.exec_module(module)
    except BaseException:
        sys.modules.pop("demcal", None)
        sys.modules.pop("demcal._demcal", None)
        raise
    return f"demcal: python/demcal/*.py of {REPO} over the native module {native}"


_WHICH = _import_demcal()

import demcal  # noqa: E402


def pytest_report_header(config: Any) -> List[str]:
    return [_WHICH, f"demcal {demcal.__version__}"]


# ---------------------------------------------------------------------------------------------
# Inputs

QUICKSTART_TEST = REPO / "examples" / "quickstart" / "repose.toml"

#: A bonded bar of 39 spheres pulled apart (crates/test-support BONDED_BAR_PARTS with the
#: tension table of crates/virtual-tests/tests/mechanical.rs): under a second on 2 cores, with a
#: force-displacement curve. At 1 m/s instead of 0.05 it is refused as not quasi-static.
TENSION_TOML = """\
test = "tension"
seed = 1

[[material]]
name = "stalk"
density = 136.4
poisson_ratio = 0.357
shear_modulus = 1.511e8

[[material]]
name = "steel"
density = 7850
poisson_ratio = 0.3
shear_modulus = 7.9e10

[[interaction]]
materials = ["stalk", "stalk"]
restitution = 0.47
static_friction = 0.28
rolling_friction = 0.16

[[interaction]]
materials = ["stalk", "steel"]
restitution = 0.52
static_friction = 0.45
rolling_friction = 0.24

[[interaction]]
materials = ["steel", "steel"]
restitution = 0.5
static_friction = 0.2
rolling_friction = 0.01

[[bond]]
materials = ["stalk", "stalk"]
normal_stiffness = 1e9
shear_stiffness = 1e9
critical_normal_stress = 2e5
critical_shear_stress = 1e6
bonded_disk_scale = 1.0
contact_radius_scale = 1.05

[tension]
specimen = { material = "stalk", radius = 0.001, length = 0.012, diameter = 0.006 }
fixture_material = "steel"
speed = 0.05
max_displacement = 0.002
stop_force_fraction = 0.2
curve_points = 300
grip_length = 0.003
"""

#: 891 glass spheres (r = 2 mm) on a simple cubic lattice settling in an open box: 2000 steps
#: take about 0.3 s on 2 cores.
BOX_SCENE_TOML = """\
[simulation]
steps = 2000
time_step_percent = 20
gravity = [0.0, 0.0, -9.81]
domain = { min = [-0.01, -0.01, -0.01], max = [0.05, 0.05, 0.2] }

[[material]]
name = "glass"
density = 2500.0
poisson_ratio = 0.3
youngs_modulus = 1.0e7

[[interaction]]
materials = ["glass", "glass"]
restitution = 0.5
static_friction = 0.5
rolling_friction = 0.05

[[geometry]]
name = "box"
type = "box"
material = "glass"
min = [0.0, 0.0, 0.0]
max = [0.04, 0.04, 0.15]
open = ["+z"]

[[particles]]
material = "glass"
size = { type = "fixed", radius = 0.002 }
region = { type = "box", min = [0.002, 0.002, 0.002], max = [0.038, 0.038, 0.05] }
fill = { type = "lattice", lattice = "sc", spacing = 0.0045 }
"""

#: The study of crates/study/tests/studies.rs (BOWL): a bowl whose only minimum, 30, lies at
#: a = 0.6, b = 0.3 (c and d barely matter), with noise 0.02; runs with c + d > 1.7 fail as
#: `diverged`. The plan makes 13 + 5 + 13 + 3 = 34 runs, 3 of them failed.
BOWL = """\
name = "bowl"
seed = 3
plan = ["screening", "steepest", "rsm", "optimize", "validate"]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2) + 0.01*c + 0.01*d"
variables = { a = 0.8, b = 0.5, c = 0.5, d = 0.5 }
noise = 0.02
fail_when = "c + d - 1.7"

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.4
max = 1.2

[[parameter]]
name = "b"
path = "function.variables.b"
min = 0.1
max = 0.9

[[parameter]]
name = "c"
path = "function.variables.c"
min = 0.0
max = 1.0

[[parameter]]
name = "d"
path = "function.variables.d"
min = 0.0
max = 1.0

[target]
value = 30.0
"""


def bowl_value(a: float, b: float, c: float, d: float) -> float:
    """BOWL's formula without noise."""
    return 30 + 10 * ((a - 0.6) ** 2 + (b - 0.3) ** 2) + 0.01 * c + 0.01 * d


def write_study(folder: Path, text: str = BOWL, name: str = "study.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def function_table(expression: str, **variables: float) -> Dict[str, Any]:
    """A `function` test as a dict: `expression` of `variables`, no noise."""
    return {"test": "function", "function": {"expression": expression, "variables": dict(variables)}}


@pytest.fixture(scope="session")
def quickstart() -> "demcal.Test":
    return demcal.Test.load(QUICKSTART_TEST)


@pytest.fixture(scope="session")
def tension_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("tension") / "bar.toml"
    path.write_text(TENSION_TOML, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def tension(tension_file: Path) -> "demcal.Test":
    return demcal.Test.load(tension_file)


@pytest.fixture(scope="session")
def box_scene_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("scene") / "box.toml"
    path.write_text(BOX_SCENE_TOML, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def demcal_binary() -> Path:
    """The `demcal` binary of this checkout (DEMCAL_BIN, else the newest of target/*/demcal)."""
    given = os.environ.get("DEMCAL_BIN")
    if given:
        return Path(given)
    found = [p for p in (REPO / "target").glob("*/demcal") if p.is_file() and os.access(p, os.X_OK)]
    if not found:
        pytest.skip("no demcal binary (cargo build -p demcal-cli, or set DEMCAL_BIN): the CLI comparison needs one")
    return max(found, key=lambda p: p.stat().st_mtime)


# ---------------------------------------------------------------------------------------------
# Ctrl-C from a timer thread


class Interrupt:
    """When the SIGINT was sent (perf_counter), once it was."""

    sent_at: Optional[float] = None


@contextlib.contextmanager
def interrupt_after(seconds: float) -> Iterator[Interrupt]:
    """Sends SIGINT to the main thread `seconds` after entering (as Ctrl-C would), unless the
    block has ended by then. The block must be in the main thread."""
    assert threading.current_thread() is threading.main_thread()
    record = Interrupt()
    cancelled = threading.Event()

    def fire() -> None:
        if not cancelled.wait(seconds):
            record.sent_at = time.perf_counter()
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)  # type: ignore[arg-type]

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Thread(target=fire, daemon=True)
    timer.start()
    try:
        yield record
    finally:
        cancelled.set()
        timer.join()
        signal.signal(signal.SIGINT, previous)
