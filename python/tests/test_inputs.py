"""inputs={"node": array}: an array in place of a node's output, keyed by its content."""

import numpy as np
import pytest

import hdrflow

GRAPH = """(nodes: {
    "env": LoadHdr(path: "builtin:sky"),
    "exp": Exposure(image: "env", stops: 1.0),
})"""


def test_an_array_replaces_the_node_and_its_content_is_the_cache_key(cache):
    env = np.random.default_rng(1).random((4, 6, 3))  # float64: converted to float32
    r = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": env}, cache_dir=cache)
    assert r.status("env") == "provided" and r.status("exp") == "computed"
    assert r["exp"].shape == (4, 6, 3) and r["exp"].dtype == np.float32
    assert np.array_equal(r["exp"], env.astype(np.float32) * 2)

    # The same content (another array object): the consumer is served from the cache.
    again = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": env.copy()}, cache_dir=cache)
    assert again.status("exp") == "cached"
    key = {n["name"]: n["key"] for n in r.report["nodes"]}
    assert all(key[n["name"]] == n["key"] for n in again.report["nodes"])

    # One value changed: another key, recomputed.
    env[0, 0, 0] += 1.0
    changed = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": env}, cache_dir=cache)
    assert changed.status("exp") == "computed"
    assert {n["name"]: n["key"] for n in changed.report["nodes"]}["env"] != key["env"]


def test_the_shape_is_in_the_key_and_rgba_keeps_alpha(cache):
    flat = np.ones((2, 8, 3), np.float32)
    a = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": flat}, cache_dir=cache)
    b = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": flat.reshape(4, 4, 3)}, cache_dir=cache)
    assert b.status("exp") == "computed" and b["exp"].shape == (4, 4, 3)
    assert a.report["nodes"][0]["key"] != b.report["nodes"][0]["key"]
    rgba = hdrflow.run(GRAPH, targets=["exp"], inputs={"env": np.full((2, 2, 4), 0.5)}, cache_dir=cache)
    assert rgba.channels("exp") == ["R", "G", "B", "A"]
    assert np.array_equal(rgba["exp"][..., 3], np.full((2, 2), 0.5, np.float32))  # alpha is not scaled


def test_a_one_channel_array_is_a_scalar_field(cache):
    graph = '(nodes: {"y": Luminance(image: "env"), "env": LoadHdr(path: "builtin:sky"), "e": Exposure(image: "y", stops: 2.0)})'
    r = hdrflow.run(graph, targets=["e"], inputs={"y": np.ones((3, 5))}, cache_dir=cache)
    assert r["e"].shape == (3, 5, 1) and r.channels("e") == ["Y"]
    assert np.all(r["e"] == 4.0)
    assert r.status("env") == "not needed"  # what only the provided node needed is not run
    with pytest.raises(ValueError, match="outputs `image`, but the value provided is `scalar field`"):
        hdrflow.run(GRAPH, targets=["exp"], inputs={"env": np.ones((3, 5))}, cache_dir=cache)
    with pytest.raises(ValueError, match="no node \"nope\""):
        hdrflow.run(GRAPH, inputs={"nope": np.ones((3, 5, 3))}, cache_dir=cache)


def test_other_ports_come_back_as_node_dot_port(cache):
    graph = GRAPH.replace("})", '    "d": Difference(a: "exp", b: "env"),\n})')
    env = np.full((3, 4, 3), 0.25)
    r = hdrflow.run(graph, targets=["d"], inputs={"env": env}, cache_dir=cache)
    assert set(r) == {"d", "d.error", "d.metrics"}
    assert r["d"].ndim == 3 and r["d"].shape[2] >= 3  # the heat map (with its legend)
    assert r["d.error"].shape == (3, 4, 1) and r.channels("d.error") == ["E"]
    assert r["d.metrics"]["max"] == pytest.approx(float(r["d.error"].max()))
    assert "d.metrics" in r and "d.nope" not in r and len(r) == 3
    with pytest.raises(KeyError, match="pass targets"):
        r["exp"]
