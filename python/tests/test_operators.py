"""Python operators: registered with @hdrflow.operator, used from RON like any operator."""

import numpy as np
import pytest

import hdrflow

GRAPH = """(nodes: {
    "env": LoadHdr(path: "builtin:sky"),
    "g": PyGammaTest(image: "env", gamma: 2.0),
})"""

CALLS = []


def test_a_python_operator_runs_is_cached_and_recomputes_when_its_source_or_version_changes(cache):
    @hdrflow.operator(name="PyGammaTest", fields={"image": "image", "gamma": 2.2}, output="image", version=1)
    def gamma(image, gamma):
        CALLS.append(gamma)
        return np.power(np.maximum(image, 0.0), 1.0 / gamma)

    env = np.random.default_rng(2).random((4, 4, 3)).astype(np.float32)
    r = hdrflow.run(GRAPH, inputs={"env": env}, cache_dir=cache)
    assert r.status("g") == "computed" and CALLS == [2.0]
    assert np.allclose(r["g"], np.sqrt(env), rtol=1e-6)

    again = hdrflow.run(GRAPH, inputs={"env": env}, cache_dir=cache)
    assert again.status("g") == "cached" and CALLS == [2.0]
    assert np.array_equal(again["g"], r["g"])

    # A parameter from set= is a new key.
    hdrflow.run(GRAPH, inputs={"env": env}, set={"g.gamma": 4}, cache_dir=cache)
    assert CALLS == [2.0, 4.0]

    # The same name, an edited body: recomputed.
    @hdrflow.operator(name="PyGammaTest", fields={"image": "image", "gamma": 2.2}, output="image", version=1)
    def gamma(image, gamma):  # noqa: F811
        CALLS.append(-gamma)
        return np.power(np.maximum(image, 0.0), 1.0 / gamma) * 1.0
    edited = hdrflow.run(GRAPH, inputs={"env": env}, cache_dir=cache)
    assert edited.status("g") == "computed" and CALLS[-1] == -2.0
    assert hdrflow.run(GRAPH, inputs={"env": env}, cache_dir=cache).status("g") == "cached"

    # The same source, a new version: recomputed.
    @hdrflow.operator(name="PyGammaTest", fields={"image": "image", "gamma": 2.2}, output="image", version=2)
    def gamma(image, gamma):  # noqa: F811
        CALLS.append(-gamma)
        return np.power(np.maximum(image, 0.0), 1.0 / gamma) * 1.0
    assert hdrflow.run(GRAPH, inputs={"env": env}, cache_dir=cache).status("g") == "computed"


def test_python_operators_mix_with_built_ins_on_the_engine_s_threads(root, cache):
    @hdrflow.operator(name="PyScaleTest", fields={"image": "scalar_field", "k": 3, "negate": False}, output="scalar_field")
    def scale(image, k, negate):
        assert image.shape[2] == 1 and isinstance(k, int) and negate is False
        return (image * k)[:, :, 0]  # (H, W) is accepted for a scalar field

    graph = """(nodes: {
        "env": LoadHdr(path: "builtin:sky"),
        "lum": Luminance(image: "env"),
        "a": PyScaleTest(image: "lum"),
        "b": PyScaleTest(image: "lum", k: 5),
        "sum": Exposure(image: "a", stops: 1.0),
    })"""
    # Several Python nodes on worker threads while the caller waits: the run releases the GIL
    # (otherwise this would deadlock), each Python node takes it.
    r = hdrflow.run(graph, targets=["sum", "b", "lum"], cache_dir=cache, jobs=2)
    assert np.allclose(r["sum"], r["lum"] * 6) and np.allclose(r["b"], r["lum"] * 5)


def test_a_python_operator_s_exception_is_a_run_error_and_its_fields_are_validated(cache):
    @hdrflow.operator(name="PyFailTest", fields={"image": "image", "mode": "strict"})
    def fail(image, mode):
        raise ZeroDivisionError(f"no luck in {mode} mode")

    graph = '(nodes: {"env": LoadHdr(path: "builtin:sky"), "f": PyFailTest(image: "env")})'
    with pytest.raises(hdrflow.RunError, match=r"node \"f\" \(PyFailTest\).*ZeroDivisionError: no luck in strict mode"):
        hdrflow.run(graph, cache_dir=cache)
    with pytest.raises(hdrflow.PipelineError, match=r"<string>:1:\d+: node \"f\".*mode"):
        hdrflow.run('(nodes: {"env": LoadHdr(path: "builtin:sky"), "f": PyFailTest(image: "env", mode: 3)})', cache_dir=cache)

    @hdrflow.operator(name="PyBadShapeTest", fields={"image": "image"})
    def bad(image):
        return image[:, :, 0]  # one channel, but "image" was declared

    with pytest.raises(hdrflow.RunError, match="scalar field"):
        hdrflow.run('(nodes: {"env": LoadHdr(path: "builtin:sky"), "f": PyBadShapeTest(image: "env")})', cache_dir=cache)
    with pytest.raises(ValueError, match="built-in"):
        hdrflow.operator(name="Exposure", fields={"image": "image"})(lambda image: image)


def test_ops_describes_built_ins_and_python_operators():
    @hdrflow.operator(name="PyDocTest", fields={"image": "image", "gain": 1.5}, version=7)
    def doc_test(image, gain):
        """Multiplies by a gain."""
        return image * gain

    ops = {o["name"]: o for o in hdrflow.ops()}
    exposure = ops["Exposure"]
    assert exposure["category"] == "image" and exposure["version"] >= 1 and exposure["doc"]
    fields = {f["name"]: f for f in exposure["fields"]}
    assert fields["image"]["input"] and fields["stops"]["kind"].startswith("float")
    assert exposure["outputs"][0]["name"] == "image"
    mine = ops["PyDocTest"]
    assert (mine["category"], mine["version"], mine["doc"]) == ("python", 7, "Multiplies by a gain.")
    assert [(f["name"], f["kind"], f["default"]) for f in mine["fields"]] == [
        ("image", "input<image>", None), ("gain", "float", 1.5)
    ]


def test_a_function_without_source_is_keyed_by_its_compiled_code(cache):
    def define(body):
        scope = {"hdrflow": hdrflow}
        exec(
            "@hdrflow.operator(name='PyExecTest', fields={'image': 'image'})\n"
            f"def f(image):\n    return {body}\n",
            scope,
        )

    graph = '(nodes: {"env": LoadHdr(path: "builtin:sky"), "x": PyExecTest(image: "env")})'
    env = np.ones((2, 2, 3), np.float32)
    define("image * 2")
    assert hdrflow.run(graph, inputs={"env": env}, cache_dir=cache)["x"][0, 0, 0] == 2
    define("image * 2")
    assert hdrflow.run(graph, inputs={"env": env}, cache_dir=cache).status("x") == "cached"
    define("image * 3")
    r = hdrflow.run(graph, inputs={"env": env}, cache_dir=cache)
    assert r.status("x") == "computed" and r["x"][0, 0, 0] == 3


def test_a_type_name_near_miss_is_an_error_not_a_string_parameter():
    with pytest.raises(ValueError, match=r"'Image' is not a value type; did you mean 'image'\?"):
        hdrflow.operator("NearMiss", fields={"x": "Image"})(lambda x: x)
    with pytest.raises(ValueError, match=r"did you mean 'scalar_field'\?|did you mean 'scalar field'\?"):
        hdrflow.operator("NearMiss2", fields={"x": "scalar_feild"})(lambda x: x)
    # A string parameter far from every type name is still a parameter.
    hdrflow.operator("FarFromTypes", fields={"x": "image", "label": "hello"})(lambda x, label: x)


def test_op_runs_one_operator_on_arrays_and_caches_it(cache):
    env = np.random.default_rng(3).random((8, 16, 3)).astype(np.float32)
    out = hdrflow.op("Exposure", image=env, stops=1.0, cache_dir=cache)
    assert out.shape == (8, 16, 3) and np.array_equal(out, env * 2)
    # A whole-column yaw is an exact roll (the book's Rotations, docs/src/conventions.md): 90 degrees = 4 columns.
    rolled = hdrflow.op("Rotate", image=env, yaw=90, cache_dir=cache)
    assert np.array_equal(rolled, np.roll(env, -4, axis=1)) or np.array_equal(rolled, np.roll(env, 4, axis=1))
    # One channel is a scalar field; a file name is loaded.
    y = hdrflow.op("Luminance", image="builtin:sky", cache_dir=cache)
    assert y.ndim == 3 and y.shape[2] == 1
    field = hdrflow.op("Exposure", image=y[:, :, 0], stops=-1.0, cache_dir=cache)
    assert np.allclose(field, y * 0.5)
    with pytest.raises(ValueError, match="did you mean 'Rotate'"):
        hdrflow.op("Rotat", image=env)
    with pytest.raises(ValueError, match=r"unknown parameter 'yawn' \(did you mean 'yaw'\?\)"):
        hdrflow.op("Rotate", image=env, yawn=3, cache_dir=cache)
