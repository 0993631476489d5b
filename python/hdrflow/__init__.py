"""hdrflow from Python: run pipelines, feed NumPy arrays into them, write operators in Python.

The same library as the ``hdrflow`` command line (``hdrflow._hdrflow`` is a Rust extension over
it): pipelines are validated, scheduled and cached exactly as ``hdrflow run`` does.

    >>> import hdrflow
    >>> r = hdrflow.run("graphs/seed.ron")
    >>> r["sphere_1024"].shape
    (256, 256, 3)

See the book's "Python" page (docs/src/guides/python.md) for the whole story.
"""

from __future__ import annotations

import difflib
import inspect
import json
import marshal
import os
import re
import textwrap
from typing import Any, Callable, Iterator, Mapping, Optional, Sequence, Union

import numpy as np

from . import _hdrflow
from ._hdrflow import PipelineError, RunError

__all__ = ["run", "batch", "op", "ops", "operator", "Result", "Ron", "PipelineError", "RunError", "value_types"]


class Ron(str):
    """Raw RON text for ``set=``: ``set={"lum.weights": hdrflow.Ron("Rec2020")}``.

    A plain ``str`` in ``set=`` is a RON *string* (quoted for you); wrap a value in ``Ron`` to
    pass it as written (a choice like ``Rec709``, a list, a tuple written by hand).
    """


def _ron_string(s: str) -> str:
    """A RON string literal: quotes and backslashes escaped, control characters as ``\\u{..}``."""
    out = []
    for c in s:
        if c in '"\\':
            out.append("\\" + c)
        elif c == "\n":
            out.append("\\n")
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{{{ord(c):x}}}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def _to_ron(value: Any) -> str:
    """A Python value as RON text (what ``--set NODE.FIELD=VALUE`` takes)."""
    if isinstance(value, Ron):
        return str(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if v != v or v in (float("inf"), float("-inf")):
            raise ValueError(f"{v} cannot be written in a pipeline")
        return repr(v)
    if isinstance(value, str):
        return _ron_string(value)
    if isinstance(value, tuple):
        return "(" + ", ".join(_to_ron(v) for v in value) + ")"
    if isinstance(value, list):
        return "[" + ", ".join(_to_ron(v) for v in value) + "]"
    if isinstance(value, os.PathLike):
        return _ron_string(os.fspath(value))
    raise TypeError(f"cannot write a {type(value).__name__} as a pipeline value")


def _image_array(a: Any, what: str) -> np.ndarray:
    """An array as the engine's image layout: float32, C-contiguous, (H, W, C)."""
    arr = np.asarray(a)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3:
        raise ValueError(f"{what}: expected an (H, W) or (H, W, C) array, got shape {arr.shape}")
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{what}: expected a float array, got {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.float32)


class Result(Mapping):
    """A finished run: values by ``"node"`` (default port) and ``"node.port"`` (other ports).

    ``report`` is the ``--report`` JSON as a dict; ``channels(key)`` an image's channel names.
    """

    def __init__(self, values: dict, report: dict, channels: dict):
        self._values = values
        self.report = report
        self._channels = channels

    def __getitem__(self, key: str) -> Any:
        try:
            return self._values[key]
        except KeyError:
            names = ", ".join(sorted(self._values))
            raise KeyError(f"{key!r} is not among this run's results ({names}); pass targets=[...] to get it") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __contains__(self, key: object) -> bool:
        return key in self._values

    def channels(self, key: str) -> list:
        """Channel names of an image result, e.g. ``["R", "G", "B"]`` or ``["Y"]``."""
        return list(self._channels[key])

    def status(self, node: str) -> str:
        """What happened to a node: "computed", "cached", "not needed" or "provided"."""
        for n in self.report["nodes"]:
            if n["name"] == node:
                return n["status"]
        raise KeyError(node)

    def __repr__(self) -> str:
        counts: dict = {}
        for n in self.report["nodes"]:
            counts[n["status"]] = counts.get(n["status"], 0) + 1
        summary = ", ".join(f"{v} {k}" for k, v in counts.items())
        return f"<hdrflow.Result: {len(self)} values ({summary}; {self.report['total_ms']:.1f} ms)>"


def run(
    pipeline: Union[str, os.PathLike],
    set: Optional[Mapping[str, Any]] = None,
    targets: Optional[Sequence[str]] = None,
    out: Optional[Union[str, os.PathLike]] = None,
    cache_dir: Optional[Union[str, os.PathLike]] = None,
    jobs: Optional[int] = None,
    inputs: Optional[Mapping[str, Any]] = None,
    no_cache: bool = False,
) -> Result:
    """Validates and runs a pipeline; returns its targets' values.

    pipeline: a path to a pipeline file (a ``PathLike``, or a ``str`` naming an existing file),
        else RON text (relative paths in it resolve against the working folder).
    set: ``{"node.field": value}``, like ``--set``: a RON text in ``hdrflow.Ron``, or a Python
        bool/int/float/str/tuple/list converted to RON (a ``str`` becomes a RON string).
    targets: node names to evaluate (and return). Default: what ``hdrflow run`` runs plus the
        values its Save nodes write (without ``out``, the Save nodes themselves are left out).
    out: output folder for Save nodes. Default ``None``: no file is written.
    cache_dir: the cache folder (default as the command line: ``$HDRFLOW_CACHE_DIR``, else
        ``$XDG_CACHE_HOME/hdrflow``, else ``~/.cache/hdrflow``); ``no_cache=True`` for none.
    jobs: worker threads (default: one per core).
    inputs: ``{"node": array}``: the array is that node's value (the node is not evaluated);
        (H, W) or (H, W, C) float, converted to float32; C=1 is a scalar field, 3 RGB, 4 RGBA.

    Raises ``PipelineError`` (a ``ValueError``) when the pipeline does not validate, with the
    command line's ``file:line:col`` messages, and ``RunError`` when the run fails. The GIL is
    released while the engine runs.
    """
    if isinstance(pipeline, os.PathLike):
        text, is_path = os.fspath(pipeline), True
    elif isinstance(pipeline, str):
        # RON text has a parenthesis; anything else is a file name (a missing file is a
        # PipelineError with the command line's message).
        is_path = os.path.isfile(pipeline) or ("(" not in pipeline and "\n" not in pipeline)
        text = pipeline
    else:
        raise TypeError("pipeline: a path or RON text")
    overrides = [f"{k}={_to_ron(v)}" for k, v in (set or {}).items()]
    arrays = [(name, _image_array(a, f"inputs[{name!r}]")) for name, a in (inputs or {}).items()]
    values, report, channels = _hdrflow.run_pipeline(
        text,
        is_path=is_path,
        overrides=overrides,
        targets=list(targets) if targets is not None else None,
        out=os.fspath(out) if out is not None else None,
        cache_dir=os.fspath(cache_dir) if cache_dir is not None else None,
        no_cache=bool(no_cache),
        jobs=jobs,
        inputs=arrays,
    )
    return Result(values, json.loads(report), channels)


def _axes(spec: Any, over: bool) -> list:
    """``{"node.field": "glob-or-a,b,c" | [values]}`` (or a list of such pairs) as axes."""
    if spec is None:
        return []
    pairs = spec.items() if isinstance(spec, Mapping) else spec
    axes = []
    for label, value in pairs:
        if isinstance(value, (list, tuple)):
            # Explicit values: RON text like run(set=...), except that a str path of `over` is
            # taken as written (as on the command line).
            values = [str(v) if over and isinstance(v, (str, os.PathLike)) and not isinstance(v, Ron)
                      else _to_ron(v) for v in value]
            axes.append((label, [os.fspath(v) if isinstance(v, os.PathLike) else v for v in values], over))
        else:
            axes.append((f"{label}={os.fspath(value) if isinstance(value, os.PathLike) else value}", None, over))
    return axes


def batch(
    graph: Union[str, os.PathLike],
    over: Any = None,
    sweep: Any = None,
    out: Union[str, os.PathLike] = "out",
    jobs: Optional[int] = None,
    cache_dir: Optional[Union[str, os.PathLike]] = None,
    keep_going: bool = False,
    zip: bool = False,
    item_dir: Optional[str] = None,
) -> list:
    """``hdrflow batch``: runs a pipeline file once per item, each into its own folder of ``out``.

    over: ``{"env.path": "maps/*.hdr"}`` (a glob, or a comma-separated list, as ``--over``) or
        ``{"env.path": ["a.hdr", "b.hdr"]}``; sweep: ``{"samples.count": [64, 256]}`` or
        ``{"samples.count": "64,256"}`` (as ``--sweep``). Several axes form their cross product,
        or their pairing with ``zip=True``. A dict keeps its order; a list of pairs works too.
    Returns the report rows (``--report``'s JSON): ``item``, ``index``, ``values``, ``status``
    ("computed", "cached" or "failed"), ``ms``, ``error``, ``evaluations``, ``metrics``. A failed
    item is a row, not an exception (without ``keep_going`` no new item starts after it);
    validation errors raise ``PipelineError`` before anything runs.
    """
    rows = _hdrflow.run_batch(
        os.fspath(graph),
        axes=_axes(over, True) + _axes(sweep, False),
        zip=bool(zip),
        item_dir=item_dir,
        out=os.fspath(out),
        cache_dir=os.fspath(cache_dir) if cache_dir is not None else None,
        jobs=jobs,
        keep_going=bool(keep_going),
    )
    return json.loads(rows)


def ops() -> list:
    """Every operator (built-in and registered from Python): name, category, version, doc,
    outputs, and fields with kind, default and doc (what ``hdrflow ops`` prints)."""
    return _hdrflow.ops()


def value_types() -> list:
    """The value type names (``image``, ``scalar field``, ...)."""
    return _hdrflow.value_types()


def _param_kind(name: str, default: Any) -> str:
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, (int, np.integer)):
        return "int"
    if isinstance(default, (float, np.floating)):
        return "float"
    if isinstance(default, str):
        return "str"
    raise TypeError(f"field {name!r}: a default of type {type(default).__name__} (use float, int, bool or str)")


def _near_type_name(spec: str, types: Mapping[str, str]) -> Optional[str]:
    """The value type ``spec`` is a near miss of (other case, a typo), if any."""
    lower = {t.lower(): t for t in types}
    if spec.lower() in lower:
        return lower[spec.lower()]
    close = difflib.get_close_matches(spec.lower(), list(lower), n=1, cutoff=0.8)
    return lower[close[0]] if close else None


def _op_error(name: str, problems: list) -> PipelineError:
    """A ``PipelineError`` of ``op(name, ...)``: each problem, (keyword argument or ``None``,
    message), under the call as the caller wrote it (``hdrflow.op("Rotate", yaw=...)``), never
    under the one-node pipeline ``op`` writes for them. ``errors`` holds them as dicts with the
    keys of ``run``'s, plus ``argument``."""
    texts, errors = [], []
    for argument, message in problems:
        call = f'hdrflow.op("{name}", {argument}=...)' if argument else f'hdrflow.op("{name}", ...)'
        texts.append(f"{call}: {message}")
        errors.append({"source": call, "line": None, "col": None, "node": None, "argument": argument,
                       "message": message, "text": texts[-1]})
    err = PipelineError("\n".join(texts))
    err.errors = errors
    return err


def op(
    name: str,
    /,
    *,
    cache_dir: Optional[Union[str, os.PathLike]] = None,
    no_cache: bool = False,
    **fields: Any,
) -> Any:
    """Runs one operator on arrays, for a notebook: ``hdrflow.op("Rotate", image=env, yaw=90)``.

    Each input field takes an array ((H, W) or (H, W, C) float: C=1 a scalar field), a file
    name or ``builtin:`` map (loaded with ``LoadHdr``), or a list of these for a list input;
    every other field is a parameter, converted as ``run(set=...)`` converts values. Returns the
    value of the operator's first output port (an array for images; the other ports of a node
    come back from ``run``). It builds and runs a one-node pipeline, validated and cached as any
    run is (the arrays' contents are in the key). A ``PipelineError`` names the keyword argument
    at fault: ``hdrflow.op("Rotate", yaww=...): unknown parameter 'yaww' (did you mean 'yaw'?)``.
    """
    every = ops()
    spec = next((o for o in every if o["name"] == name), None)
    if spec is None:
        names = [o["name"] for o in every]
        close = difflib.get_close_matches(name, names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f" (operators: {', '.join(names)})"
        raise ValueError(f"unknown operator {name!r}{hint}")
    known = [f["name"] for f in spec["fields"]]
    unknown = []
    for field in fields:
        if field not in known:
            close = difflib.get_close_matches(field, known, n=1)
            hint = f"did you mean {close[0]!r}?" if close else f"{name} takes {', '.join(known)}"
            unknown.append((field, f"unknown parameter {field!r} ({hint})"))
    if unknown:
        raise _op_error(name, unknown)
    inputs_of = {f["name"] for f in spec["fields"] if f["input"]}
    # The pipeline's text, one keyword argument per line, so that a validation error's line
    # names the argument it comes from.
    lines = ["(nodes: {"]
    argument_of: dict = {}  # line -> keyword argument
    argument_of_node: dict = {}  # a placeholder node (an input's array or file) -> its argument
    arrays: dict = {}

    def emit(line: str, argument: str) -> None:
        lines.append(line)
        argument_of[len(lines)] = argument

    def source(field: str, k: int, value: Any) -> str:
        node = f"{field}_{k}"
        argument_of_node[node] = field
        if isinstance(value, (str, os.PathLike)):
            path = os.fspath(value)
            path = path if path.startswith("builtin:") else os.path.abspath(path)
            emit(f'    "{node}": LoadHdr(path: {_ron_string(path)}),', field)
            return node
        arr = _image_array(value, f'hdrflow.op("{name}", {field}=...)')
        # A placeholder of the array's type and size (operators check sizes before running);
        # the array is its value, so the placeholder is not run.
        h, w = arr.shape[:2]
        if arr.shape[2] == 1:
            emit(f'    "{node}_src": Constant(width: {w}, height: {h}),', field)
            emit(f'    "{node}": Luminance(image: "{node}_src"),', field)
        else:
            emit(f'    "{node}": Constant(width: {w}, height: {h}),', field)
        arrays[node] = arr
        return node

    written = []
    for field, value in fields.items():
        if field in inputs_of:
            if isinstance(value, (list, tuple)):
                refs = [source(field, k, v) for k, v in enumerate(value)]
                written.append(f"{field}: [{', '.join(_ron_string(r) for r in refs)}]")
            else:
                written.append(f"{field}: {_ron_string(source(field, 0, value))}")
        else:
            written.append(f"{field}: {_to_ron(value)}")
    lines.append(f'    "op": {name}(')
    for field, line in zip(fields, written):
        emit(f"        {line},", field)
    lines += ["    ),", "})"]
    try:
        r = run("\n".join(lines), targets=["op"], inputs=arrays, cache_dir=cache_dir, no_cache=no_cache)
    except PipelineError as e:
        problems = [(argument_of.get(x.get("line")), x["message"]) for x in getattr(e, "errors", [])]
        raise _op_error(name, problems or [(None, str(e))]) from None
    except RunError as e:
        # `node "image_0" (LoadHdr): message`: the node is one op wrote, so name the argument.
        m = re.match(r'node "([^"]*)" \([^)]*\): (.*)', str(e), re.DOTALL)
        if m is None:
            raise
        argument = argument_of_node.get(m.group(1))
        call = f'hdrflow.op("{name}", {argument}=...)' if argument else f'hdrflow.op("{name}", ...)'
        raise RunError(f"{call}: {m.group(2)}") from None
    return r["op"]


def operator(
    name: str,
    fields: Mapping[str, Any],
    output: str = "image",
    version: int = 1,
    doc: Optional[str] = None,
    category: str = "python",
) -> Callable[[Callable], Callable]:
    """Registers a Python function as an operator that pipelines use by ``name``.

    ``fields``: ``{"image": "image", "gamma": 2.2}``: a value naming a value type (``"image"``,
    ``"scalar_field"``, ...; see ``value_types()``) is an input of that type, any other value a
    parameter with that default (its type, float/int/bool/str, from the default). The function
    gets every field as a keyword argument (inputs as float32 (H, W, C) arrays, which it may
    modify) and returns an (H, W) or (H, W, C) array (``output``: ``"image"`` for 2+ channels,
    ``"scalar_field"`` for one). Results are cached like any operator's: the key holds the
    function's source (``inspect.getsource``) and ``version``, so editing either recomputes.
    Registering the same name again replaces the operator; built-in names are refused.
    """
    types = {t: t for t in value_types()}
    types.update({t.replace(" ", "_"): t for t in value_types()})

    def register(fn: Callable) -> Callable:
        try:
            source = textwrap.dedent(inspect.getsource(fn))
        except (OSError, TypeError):
            # No source file (python -c, exec): the compiled code stands in for it, so an edit
            # still changes the key (within one Python version).
            code = getattr(fn, "__code__", None)
            if code is None:
                raise TypeError(f"{name}: a Python function is needed (its source is in the cache key)") from None
            source = "marshal:" + marshal.dumps(code).hex()
        decl = []
        for field, spec in fields.items():
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", field):
                raise ValueError(f"field {field!r}: use an identifier")
            if isinstance(spec, str) and spec in types:
                decl.append((field, "input:" + types[spec], None, f"input ({types[spec]})"))
            elif isinstance(spec, str) and _near_type_name(spec, types):
                # "Image" for "image": a string parameter by accident, not an input.
                raise ValueError(
                    f"field {field!r}: {spec!r} is not a value type; did you mean {_near_type_name(spec, types)!r}? "
                    f"(value types: {', '.join(sorted(types))}; type names are matched exactly)"
                )
            else:
                decl.append((field, _param_kind(field, spec), spec, "parameter"))
        text = doc if doc is not None else (inspect.getdoc(fn) or f"Python function {fn.__qualname__}")
        out_type = types.get(output, output)

        def call(**kwargs: Any) -> np.ndarray:
            return _image_array(fn(**kwargs), f"the result of {name}")

        _hdrflow.register_operator(
            name,
            category=category,
            doc=text.strip().splitlines()[0],
            version=int(version),
            fields=decl,
            output=out_type,
            func=call,
            source=source,
        )
        return fn

    return register
