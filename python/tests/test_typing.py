"""The package's typing and calling conventions: the type stubs and ``py.typed`` ship inside the
package (so in the wheel), and declare exactly what the package and its extension define; the
extension's functions take keyword arguments; ``hdrflow.op`` reports a problem under the keyword
argument the caller wrote, not under the pipeline text it generates."""

import ast
import inspect
import pathlib
import re

import numpy as np
import pytest

import hdrflow
from hdrflow import _hdrflow

PACKAGE = pathlib.Path(hdrflow.__file__).resolve().parent


def stub(name: str) -> ast.Module:
    return ast.parse((PACKAGE / name).read_text(), filename=name)


def declared(module: ast.Module) -> dict:
    """Top-level names of a stub: functions (their ast node), classes and imports (None)."""
    names: dict = {}
    for node in module.body:
        if isinstance(node, ast.FunctionDef):
            names[node.name] = node
        elif isinstance(node, ast.ClassDef):
            names[node.name] = None
        elif isinstance(node, ast.ImportFrom):
            names.update({a.asname or a.name: None for a in node.names})
    return names


def stub_parameters(fn: ast.FunctionDef) -> list:
    """(name, kind) of a stub function's parameters, as ``inspect.Parameter`` kinds."""
    a = fn.args
    out = [(p.arg, inspect.Parameter.POSITIONAL_ONLY) for p in a.posonlyargs]
    out += [(p.arg, inspect.Parameter.POSITIONAL_OR_KEYWORD) for p in a.args]
    if a.vararg:
        out.append((a.vararg.arg, inspect.Parameter.VAR_POSITIONAL))
    out += [(p.arg, inspect.Parameter.KEYWORD_ONLY) for p in a.kwonlyargs]
    if a.kwarg:
        out.append((a.kwarg.arg, inspect.Parameter.VAR_KEYWORD))
    return out


def runtime_parameters(fn) -> list:
    return [(p.name, p.kind) for p in inspect.signature(fn).parameters.values()]


def test_the_stubs_and_py_typed_ship_inside_the_package():
    assert (PACKAGE / "py.typed").read_bytes() == b""
    for name in ("__init__.pyi", "_hdrflow.pyi"):
        assert isinstance(stub(name), ast.Module)


def test_the_package_stub_declares_every_public_name_with_its_parameters():
    names = declared(stub("__init__.pyi"))
    for name in hdrflow.__all__:
        assert name in names, f"{name} is public but not in __init__.pyi"
        value = getattr(hdrflow, name)
        if inspect.isfunction(value):
            assert stub_parameters(names[name]) == runtime_parameters(value), name


def test_the_extension_stub_declares_every_function_with_its_parameters():
    names = declared(stub("_hdrflow.pyi"))
    public = [n for n in dir(_hdrflow) if not n.startswith("_")]
    assert set(public) <= set(names), set(public) - set(names)
    for name in public:
        value = getattr(_hdrflow, name)
        if callable(value) and not isinstance(value, type):
            assert stub_parameters(names[name]) == runtime_parameters(value), name


def test_the_extensions_functions_take_keyword_arguments(cache):
    values, report, channels = _hdrflow.run_pipeline(
        '(nodes: {"env": LoadHdr(path: "builtin:constant")})', targets=["env"], cache_dir=str(cache)
    )
    assert values["env"].ndim == 3 and channels["env"] == ["R", "G", "B"] and '"env"' in report
    # Past the first, arguments are keyword-only: a call cannot pass them in the wrong order.
    with pytest.raises(TypeError):
        _hdrflow.run_pipeline('(nodes: {"env": LoadHdr(path: "builtin:constant")})', False)
    for fn in (_hdrflow.run_pipeline, _hdrflow.run_batch, _hdrflow.register_operator):
        kinds = [kind for _, kind in runtime_parameters(fn)]
        assert kinds[1:] and all(k == inspect.Parameter.KEYWORD_ONLY for k in kinds[1:]), fn.__name__


def test_op_errors_name_the_keyword_argument_the_caller_wrote(cache, tmp_path):
    env = np.zeros((4, 8, 3), np.float32)
    with pytest.raises(hdrflow.PipelineError) as info:
        hdrflow.op("Rotate", image=env, yaww=90, cache_dir=cache)
    assert str(info.value) == """hdrflow.op("Rotate", yaww=...): unknown parameter 'yaww' (did you mean 'yaw'?)"""
    assert [e["argument"] for e in info.value.errors] == ["yaww"]
    # Problems the engine finds (a wrong type, a value out of range) are named the same way, with
    # the engine's message, and without the position in a pipeline text the caller never saw.
    for bad in ("ninety", 1e6):
        with pytest.raises(hdrflow.PipelineError) as info:
            hdrflow.op("Rotate", image=env, yaw=bad, cache_dir=cache)
        message = str(info.value)
        assert message.startswith('hdrflow.op("Rotate", yaw=...): '), message
        assert "<string>" not in message and not re.search(r":\d+:\d+:", message), message
        assert [e["argument"] for e in info.value.errors] == ["yaw"]
    # A problem of no one argument (a required input left out) names the call.
    with pytest.raises(hdrflow.PipelineError, match=r'^hdrflow\.op\("Rotate", \.\.\.\): '):
        hdrflow.op("Rotate", yaw=90, cache_dir=cache)
    # An input's file that does not exist is a validation error of that input.
    with pytest.raises(hdrflow.PipelineError) as info:
        hdrflow.op("Rotate", image=str(tmp_path / "missing.hdr"), cache_dir=cache)
    assert str(info.value).startswith('hdrflow.op("Rotate", image=...): ') and "image_0" not in str(info.value)
    assert "missing.hdr" in str(info.value) and [e["argument"] for e in info.value.errors] == ["image"]
    # A run error of the node an input's file is loaded by names that input.
    (tmp_path / "corrupt.hdr").write_bytes(b"not a Radiance file")
    with pytest.raises(hdrflow.RunError) as info:
        hdrflow.op("Rotate", image=str(tmp_path / "corrupt.hdr"), cache_dir=cache)
    assert str(info.value).startswith('hdrflow.op("Rotate", image=...): ') and "image_0" not in str(info.value)
