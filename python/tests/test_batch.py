"""hdrflow.batch mirrors `hdrflow batch`: items, folders, report rows, the shared cache."""

import subprocess
import json

import pytest

import hdrflow

GRAPH = """(nodes: {
    "env": LoadHdr(path: "builtin:sky"),
    "e": Exposure(image: "env", stops: 0.0),
    "d": Difference(a: "env", b: "e"),
    "s": Save(input: "e", path: "e.pfm"),
    "m": Save(input: "d.metrics", path: "m.json"),
})"""


def test_a_sweep_gives_the_command_line_s_rows_and_files(tmp_path, hdrflow_bin):
    graph = tmp_path / "g.ron"
    graph.write_text(GRAPH)
    rows = hdrflow.batch(graph, sweep={"e.stops": [0.0, -1.0]}, out=tmp_path / "py", cache_dir=tmp_path / "c")
    assert [(r["item"], r["status"], r["error"]) for r in rows] == [
        ("stops=0.0", "computed", None), ("stops=-1.0", "computed", None)
    ]
    assert rows[0]["metrics"]["d.metrics.max"] == 0.0 and rows[1]["metrics"]["d.metrics.max"] > 0.0
    # Again, written as the command line's list: everything comes from the cache.
    again = hdrflow.batch(graph, sweep={"e.stops": "0.0,-1.0"}, out=tmp_path / "py", cache_dir=tmp_path / "c")
    assert [r["status"] for r in again] == ["cached", "cached"]
    # The command line's batch: the same rows (but times) and the same files, byte for byte.
    subprocess.run(
        [hdrflow_bin, "batch", str(graph), "--sweep", "e.stops=0.0,-1.0", "--out", str(tmp_path / "cli"),
         "--cache-dir", str(tmp_path / "c2"), "--report", str(tmp_path / "rows.json"), "--quiet"],
        check=True,
    )
    cli = json.loads((tmp_path / "rows.json").read_text())
    strip = lambda rs: [{k: v for k, v in r.items() if k != "ms"} for r in rs]  # noqa: E731
    assert strip(cli) == strip(rows)
    for item in ["stops=0.0", "stops=-1.0"]:
        for f in ["e.pfm", "m.json"]:
            assert (tmp_path / "cli" / item / f).read_bytes() == (tmp_path / "py" / item / f).read_bytes()


def test_batch_validation_errors_name_the_item(tmp_path):
    graph = tmp_path / "g.ron"
    graph.write_text(GRAPH)
    with pytest.raises(hdrflow.PipelineError, match=r'^item "stops=loud": --set e.stops:1:1: node "e": field "stops"'):
        hdrflow.batch(graph, sweep={"e.stops": [1.0, "loud"]}, out=tmp_path / "o", cache_dir=tmp_path / "c")
