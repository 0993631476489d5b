"""Errors: PipelineError (a ValueError) with the command line's file:line:col messages, RunError;
a bad HDRFLOW_CPU fails the import."""

import os
import subprocess
import sys

import pytest

import hdrflow


def test_validation_errors_carry_file_line_and_column(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text('(nodes: {\n    "env": LoadHdr(path: "builtin:sky"),\n    "e": Exposure(image: "env", stopz: 1.0),\n})\n')
    with pytest.raises(hdrflow.PipelineError) as info:
        hdrflow.run(bad)
    assert isinstance(info.value, ValueError)
    message = str(info.value)
    assert f"{bad}:3:" in message and 'node "e"' in message and "stopz" in message
    first = info.value.errors[0]
    assert (first["source"], first["line"], first["node"]) == (str(bad), 3, "e") and first["col"] > 1


def test_every_problem_is_reported_and_set_is_validated_too(cache):
    text = '(nodes: {"a": Exposure(image: "x", stops: 1.0), "b": Exposure(image: "a", stops: "one")})'
    with pytest.raises(hdrflow.PipelineError) as info:
        hdrflow.run(text, cache_dir=cache)
    assert len(info.value.errors) == 2
    assert all(e["line"] == 1 for e in info.value.errors)
    with pytest.raises(hdrflow.PipelineError, match="stops"):
        hdrflow.run('(nodes: {"env": LoadHdr(path: "builtin:sky"), "a": Exposure(image: "env", stops: 1.0)})',
                    set={"a.stops": "loud"}, cache_dir=cache)


def test_a_missing_file_and_run_errors():
    with pytest.raises(hdrflow.PipelineError, match="no-such.ron"):
        hdrflow.run("no-such.ron")
    with pytest.raises(hdrflow.RunError, match="unknown target node \"nope\""):
        hdrflow.run('(nodes: {"env": LoadHdr(path: "builtin:sky")})', targets=["nope"], no_cache=True)
    with pytest.raises(ValueError, match="writes a file: pass out="):
        hdrflow.run('(nodes: {"env": LoadHdr(path: "builtin:sky"), "s": Save(input: "env", path: "a.exr")})',
                    targets=["s"], no_cache=True)


def test_a_bad_hdrflow_cpu_fails_the_import_naming_the_variable():
    env = dict(os.environ, HDRFLOW_CPU="bogus")
    r = subprocess.run([sys.executable, "-c", "import hdrflow"], env=env, capture_output=True, text=True)
    assert r.returncode != 0
    assert 'RuntimeError: HDRFLOW_CPU="bogus" is not an instruction set' in r.stderr, r.stderr
    ok = subprocess.run([sys.executable, "-c", "import hdrflow"], env=dict(env, HDRFLOW_CPU="portable"))
    assert ok.returncode == 0
