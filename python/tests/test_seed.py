"""graphs/seed.ron from Python against the command line: the same pixels, bit for bit."""

import subprocess

import numpy as np
import pytest

import hdrflow


def load_exr(path):
    """Reads an EXR back with hdrflow itself (a one-node pipeline, no cache)."""
    r = hdrflow.run(f'(nodes: {{"x": LoadHdr(path: "{path}")}})', no_cache=True)
    return r["x"]


def test_seed_spheres_are_bit_identical_to_the_exr_files_the_command_line_writes(root, tmp_path, hdrflow_bin):
    cli_out = tmp_path / "cli"
    subprocess.run(
        [hdrflow_bin, "run", str(root / "graphs/seed.ron"), "--out", str(cli_out),
         "--cache-dir", str(tmp_path / "cli-cache"), "--quiet"],
        check=True,
    )
    r = hdrflow.run(root / "graphs/seed.ron", cache_dir=tmp_path / "py-cache")
    for node, exr in [("sphere_1024", "sphere_1024.exr"), ("sphere_1024_seed", "sphere_1024_seed_estimator.exr")]:
        ours = r[node]
        theirs = load_exr(cli_out / exr)
        assert ours.dtype == np.float32 and ours.shape == (256, 256, 3) == theirs.shape
        assert r.channels(node) == ["R", "G", "B"]
        assert np.array_equal(ours.view(np.uint32), theirs.view(np.uint32)), node
    # Every sphere came back as an image, the samples and curves as dicts. The arrays do not
    # own a copy: each wraps the engine's own buffer, moved to NumPy (its base keeps it alive).
    for n in ["sphere_64", "sphere_256", "sphere_1024", "sphere_1024_seed"]:
        assert r[n].shape == (256, 256, 3)
        assert not r[n].flags.owndata and type(r[n].base).__name__ == "PySliceContainer"
        assert r[n].flags.c_contiguous and r[n].flags.writeable
    assert r["samples_64"]["dir"].shape == (64, 3)
    assert set(r["fresnel_in"]) >= {"x", "series", "scalars"}


def test_files_written_from_python_are_byte_identical_to_the_command_line_s(root, tmp_path, hdrflow_bin):
    subprocess.run(
        [hdrflow_bin, "run", str(root / "graphs/seed.ron"), "--out", str(tmp_path / "cli"),
         "--no-cache", "--quiet"],
        check=True,
    )
    r = hdrflow.run(str(root / "graphs/seed.ron"), out=tmp_path / "py", no_cache=True)
    # A Save node's value is the path of the file it wrote.
    assert r["save_sphere_1024_exr"] == str(tmp_path / "py" / "sphere_1024.exr")
    cli_files = sorted(p.name for p in (tmp_path / "cli").iterdir())
    py_files = sorted(p.name for p in (tmp_path / "py").iterdir())
    # One file per Save node of the graph (each writes one).
    saves = [n for n in r.report["nodes"] if n["op"] == "Save"]
    assert cli_files == py_files and len(cli_files) == len(saves) >= 29
    for name in cli_files:
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name


def test_the_report_is_the_command_line_s_report_and_a_rerun_is_cached(root, cache, tmp_path, hdrflow_bin):
    first = hdrflow.run(root / "graphs/seed.ron", cache_dir=cache)
    assert first.status("sphere_1024") == "computed"
    again = hdrflow.run(root / "graphs/seed.ron", cache_dir=cache)
    assert all(n["status"] != "computed" for n in again.report["nodes"])
    assert np.array_equal(first["sphere_64"], again["sphere_64"])
    # The same keys as the command line's --report for the same pipeline.
    report = tmp_path / "report.json"
    subprocess.run(
        [hdrflow_bin, "run", str(root / "graphs/seed.ron"), "--out", str(tmp_path / "o"),
         "--cache-dir", str(tmp_path / "c2"), "--quiet", "--report", str(report)],
        check=True,
    )
    import json

    cli = json.loads(report.read_text())
    assert set(cli) == set(first.report)
    assert set(cli["nodes"][0]) == set(first.report["nodes"][0])
    keys = {n["name"]: n["key"] for n in cli["nodes"]}
    assert all(keys[n["name"]] == n["key"] for n in first.report["nodes"] if n["key"])


def test_set_overrides_like_the_command_line(root, cache):
    r = hdrflow.run(root / "graphs/seed.ron", targets=["samples_64"], set={"samples_64.count": 8}, cache_dir=cache)
    assert list(r) == ["samples_64"]
    assert r["samples_64"]["x"].shape == (8,)
    r = hdrflow.run(root / "graphs/seed.ron", targets=["lum"], set={"lum.weights": hdrflow.Ron("Mean")}, cache_dir=cache)
    assert r["lum"].shape == (256, 512, 1) and r.channels("lum") == ["Y"]


def test_set_writes_python_values_as_ron(root, cache):
    upright = hdrflow.run(root / "graphs/seed.ron", targets=["env"], cache_dir=cache)["env"]
    flipped = hdrflow.run(root / "graphs/seed.ron", targets=["env"], cache_dir=cache,
                          set={"env.path": "builtin:sky", "env.flip_vertical": True})["env"]
    assert np.array_equal(flipped, upright[::-1])
    # A str arrives as written, control characters and quotes included (a missing file: a
    # PipelineError at validation, the path printed escaped).
    with pytest.raises(hdrflow.PipelineError, match=r'nope\\t\\"q" does not exist'):
        hdrflow.run(root / "graphs/seed.ron", targets=["env"], cache_dir=cache, set={"env.path": 'nope\t"q'})
