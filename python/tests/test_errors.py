"""Errors: PipelineError (a ValueError) with the command line's file:line:col messages, RunError."""

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
