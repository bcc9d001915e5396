"""The type stubs (volkit/__init__.pyi) say what the functions take at run
time (issue 53 §2): every parameter of a function's runtime signature is
in its stub with the same kind, and the keywords a stub lists beyond them
are ones the function accepts."""

import ast
import inspect
import pathlib
import re

import numpy as np
import pytest

import volkit

STUB = pathlib.Path(volkit.__file__).with_name("__init__.pyi")


def stub_functions():
    tree = ast.parse(STUB.read_text())
    return {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}


def stub_params(fn):
    a = fn.args
    out = {}
    for p in a.posonlyargs:
        out[p.arg] = inspect.Parameter.POSITIONAL_ONLY
    for p in a.args:
        out[p.arg] = inspect.Parameter.POSITIONAL_OR_KEYWORD
    for p in a.kwonlyargs:
        out[p.arg] = inspect.Parameter.KEYWORD_ONLY
    if a.vararg:
        out[a.vararg.arg] = inspect.Parameter.VAR_POSITIONAL
    if a.kwarg:
        out["**"] = inspect.Parameter.VAR_KEYWORD
    return out


def accepted_keywords(call, pattern):
    """The keywords a `**kwargs` function names when given an unknown one."""
    with pytest.raises(ValueError) as e:
        call()
    m = re.search(pattern, str(e.value))
    assert m, str(e.value)
    return {k.strip() for k in m.group(1).split(",")}


def test_stub_functions_are_the_runtime_functions():
    stubs = stub_functions()
    assert set(stubs) == set(volkit.__all__) - {"Index", "Volume"}


@pytest.mark.parametrize("name", sorted(stub_functions()))
def test_stub_signature_matches_runtime(name):
    stub = stub_params(stub_functions()[name])
    runtime = inspect.signature(getattr(volkit, name)).parameters
    has_kwargs = False
    for p in runtime.values():
        if p.kind == inspect.Parameter.VAR_KEYWORD:
            has_kwargs = True
            continue
        assert p.name in stub, f"{name}: `{p.name}` missing from the stub"
        assert stub[p.name] == p.kind, f"{name}: `{p.name}` is {p.kind} at run time, {stub[p.name]} in the stub"
    extra = {k for k, kind in stub.items() if k not in runtime and k != "**"}
    if extra:
        assert has_kwargs, f"{name}: the stub lists {extra}, which the function does not take"


def test_open_stub_lists_exactly_the_selection_keywords(tmp_path):
    volkit.save(np.zeros((2, 2, 2), np.uint8), tmp_path / "x.vvol")
    taken = accepted_keywords(lambda: volkit.open(tmp_path / "x.vvol", no_such=1), r"open takes ([^)]*)\)")
    stub = {k for k, kind in stub_params(stub_functions()["open"]).items() if kind == inspect.Parameter.KEYWORD_ONLY}
    assert stub == taken
    # Each keyword of the stub is accepted (None: not given).
    volkit.open(tmp_path / "x.vvol", **{k: None for k in stub})


@pytest.mark.parametrize("name", ["save", "preprocess"])
def test_preprocessing_stub_keywords_are_accepted(tmp_path, name):
    a = np.zeros((2, 2, 2), np.uint8)
    args = (a, tmp_path / "x.vvol") if name == "save" else (a,)
    fn = getattr(volkit, name)
    taken = accepted_keywords(lambda: fn(*args, no_such=1), r"keywords are (.*)\)$")
    runtime = set(inspect.signature(fn).parameters)
    stub = {k for k, kind in stub_params(stub_functions()[name]).items() if kind == inspect.Parameter.KEYWORD_ONLY}
    assert stub - runtime == taken


def test_volume_stub_lists_the_runtime_attributes():
    tree = ast.parse(STUB.read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Volume")
    stub = {n.name for n in cls.body if isinstance(n, ast.FunctionDef)}
    runtime = {n for n in dir(volkit.Volume) if not n.startswith("_")}
    assert runtime <= stub, runtime - stub
    assert {n for n in stub if not n.startswith("_")} <= runtime
