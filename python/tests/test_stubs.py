"""The type stubs of the native module (python/demcal/_demcal.pyi) against the module itself:
every public name in both, the same parameters with the same defaults; and, where mypy is
installed, mypy's own stubtest and a clean type check of the package (it ships py.typed)."""

from __future__ import annotations

import ast
import inspect
import os
import subprocess
import sys

import pytest

import demcal
from demcal import _demcal

from conftest import REPO

STUB = REPO / "python" / "demcal" / "_demcal.pyi"


def stub_tree() -> ast.Module:
    return ast.parse(STUB.read_text(encoding="utf-8"))


def stub_names() -> dict:
    """The stub's public top-level definitions by name."""
    out = {}
    for node in stub_tree().body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_"):
            out[node.name] = node
    return out


def stub_all() -> list:
    for node in stub_tree().body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError("the stub has no __all__")


def runtime_names() -> set:
    return {n for n in dir(_demcal) if not n.startswith("_")}


def test_every_public_name_is_in_both():
    stub = set(stub_names())
    runtime = runtime_names()
    assert stub - runtime == set(), "in the stub, not in the module"
    assert runtime - stub == set(), "in the module, not in the stub"
    assert stub_all() == list(_demcal.__all__)


def stub_parameters(fn: ast.FunctionDef) -> list:
    """(name, default) of each parameter; default `inspect.Parameter.empty` when there is none."""
    args = fn.args
    positional = args.posonlyargs + args.args
    defaults = [inspect.Parameter.empty] * (len(positional) - len(args.defaults)) + [
        ast.literal_eval(d) for d in args.defaults]
    out = [(a.arg, d) for a, d in zip(positional, defaults)]
    out += [(a.arg, inspect.Parameter.empty if d is None else ast.literal_eval(d))
            for a, d in zip(args.kwonlyargs, args.kw_defaults)]
    return out


def runtime_parameters(obj) -> list:
    return [(p.name, p.default) for p in inspect.signature(obj).parameters.values()]


@pytest.mark.parametrize("name", sorted(n for n, node in stub_names().items() if isinstance(node, ast.FunctionDef)))
def test_functions_have_the_stubs_parameters_and_defaults(name):
    assert stub_parameters(stub_names()[name]) == runtime_parameters(getattr(_demcal, name))


def test_exceptions_have_the_stubs_bases():
    for name, node in stub_names().items():
        runtime = getattr(_demcal, name)
        if isinstance(node, ast.ClassDef) and issubclass(runtime, BaseException):
            bases = [b.id for b in node.bases]
            assert [c.__name__ for c in runtime.__bases__] == bases, name


def test_the_native_surrogate_class_matches():
    node = stub_names()["NativeSurrogate"]
    stub_members = {f.name: f for f in node.body if isinstance(f, ast.FunctionDef)}
    runtime = _demcal.NativeSurrogate
    assert set(stub_members) == {n for n in dir(runtime) if not n.startswith("_")}
    for name, f in stub_members.items():
        is_property = any(getattr(d, "id", None) == "property" for d in f.decorator_list)
        # A getter is a data descriptor at runtime, a method is not.
        assert inspect.isdatadescriptor(inspect.getattr_static(runtime, name)) == is_property, name
    assert [p for p, _ in stub_parameters(stub_members["predict"])] == ["self", "x"]
    # It cannot be made from Python, only by surrogate_fit.
    with pytest.raises(TypeError):
        runtime()


def test_the_package_exports_what_it_says():
    for name in demcal.__all__:
        assert hasattr(demcal, name), name
    for name in runtime_names():
        obj = getattr(_demcal, name)
        if isinstance(obj, type) and issubclass(obj, BaseException):
            assert getattr(demcal, name) is obj and name in demcal.__all__
    assert demcal.__version__ == _demcal.version()


def _mypy_env(tmp_path) -> dict:
    env = dict(os.environ)
    # The stub and the .py files of this checkout; the native module as installed.
    env["MYPYPATH"] = str(REPO / "python")
    env["MYPY_CACHE_DIR"] = str(tmp_path / "mypy-cache")
    return env


def test_mypy_stubtest_finds_nothing(tmp_path):
    pytest.importorskip("mypy", reason="stubtest needs mypy: pip install mypy")
    done = subprocess.run([sys.executable, "-m", "mypy.stubtest", "demcal._demcal"], cwd=tmp_path,
                          env=_mypy_env(tmp_path), capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Success: no issues found in 1 module" in done.stdout


def test_the_package_type_checks(tmp_path):
    pytest.importorskip("mypy", reason="the type check needs mypy: pip install mypy")
    done = subprocess.run([sys.executable, "-m", "mypy", str(REPO / "python" / "demcal")], cwd=tmp_path,
                          env=_mypy_env(tmp_path), capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
