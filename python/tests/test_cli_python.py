"""`hdrflow run|batch --python FILE`: Python operators from the command line (issue 25.7)."""

import os
import subprocess
import sys

import numpy as np

import hdrflow

OPS = '''
import numpy as np
import hdrflow

@hdrflow.operator(name="PyTriple", fields={"image": "image"}, output="image")
def triple(image):
    """Three times the input."""
    return image * 3.0
'''

GRAPH = """(nodes: {
    "env": Constant(width: 8, height: 4, color: (0.5, 0.25, 1.0)),
    "t": PyTriple(image: "env"),
    "save": Save(input: "t", path: "t.pfm"),
})"""


def _env():
    return dict(os.environ, HDRFLOW_PYTHON=sys.executable)


def test_run_with_python_operators(tmp_path, hdrflow_bin):
    ops, graph = tmp_path / "my_ops.py", tmp_path / "g.ron"
    ops.write_text(OPS)
    graph.write_text(GRAPH)
    out, cache = tmp_path / "out", tmp_path / "cache"
    cmd = [hdrflow_bin, "run", str(graph), "--python", str(ops), "--out", str(out), "--cache-dir", str(cache)]
    r = subprocess.run(cmd, env=_env(), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "3 nodes: 3 computed" in r.stdout, r.stdout
    img = hdrflow.op("LoadHdr", path=str(out / "t.pfm"), no_cache=True)
    assert np.allclose(img[0, 0], [1.5, 0.75, 3.0])
    # Cached the second time, like any operator.
    again = subprocess.run(cmd, env=_env(), capture_output=True, text=True)
    assert again.returncode == 0 and "0 computed" in again.stdout, again.stdout + again.stderr
    # Without --python the operator is unknown: a pipeline error (exit 2) naming it.
    plain = subprocess.run(cmd[:3] + cmd[5:], env=_env(), capture_output=True, text=True)
    assert plain.returncode == 2 and 'unknown operator "PyTriple"' in plain.stderr, plain.stderr


def test_batch_with_python_operators_and_bad_files(tmp_path, hdrflow_bin):
    ops, graph = tmp_path / "my_ops.py", tmp_path / "g.ron"
    ops.write_text(OPS)
    graph.write_text(GRAPH.replace('"t": PyTriple(image: "env")', '"e": Exposure(image: "env"),\n    "t": PyTriple(image: "e")'))
    cmd = [hdrflow_bin, "batch", str(graph), "--sweep", "e.stops=0,1", "--python", str(ops),
           "--out", str(tmp_path / "out"), "--cache-dir", str(tmp_path / "cache")]
    r = subprocess.run(cmd, env=_env(), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out" / "stops=1" / "t.pfm").is_file(), os.listdir(tmp_path / "out")
    missing = subprocess.run([hdrflow_bin, "run", str(graph), "--python", str(tmp_path / "nope.py")],
                             env=_env(), capture_output=True, text=True)
    assert missing.returncode == 2 and "nope.py: no such file" in missing.stderr, missing.stderr
