"""Type stub of ``hdrflow._hdrflow``, the Rust extension (``python/src/lib.rs``). Its functions
take every argument but the first by keyword only; ``hdrflow/__init__.py`` is the public API
over them.
"""

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

class PipelineError(ValueError):
    """A pipeline that does not validate: one ``file:line:col: node "x": message`` line per
    problem; ``errors`` has them as dicts."""

    errors: List[Dict[str, Any]]

class RunError(RuntimeError):
    """A run that failed."""

def run_pipeline(
    pipeline: str,
    *,
    is_path: bool = False,
    overrides: Sequence[str] = ...,
    targets: Optional[Sequence[str]] = None,
    out: Optional[str] = None,
    cache_dir: Optional[str] = None,
    no_cache: bool = False,
    jobs: Optional[int] = None,
    inputs: Sequence[Tuple[str, np.ndarray]] = ...,
) -> Tuple[Dict[str, Any], str, Dict[str, List[str]]]: ...
def run_batch(
    graph: str,
    *,
    axes: Sequence[Tuple[str, Optional[Sequence[str]], bool]] = ...,
    zip: bool = False,
    item_dir: Optional[str] = None,
    out: str = "out",
    cache_dir: Optional[str] = None,
    jobs: Optional[int] = None,
    keep_going: bool = False,
) -> str: ...
def ops() -> List[Dict[str, Any]]: ...
def value_types() -> List[str]: ...
def register_operator(
    name: str,
    *,
    category: str,
    doc: str,
    version: int,
    fields: Sequence[Tuple[str, str, Any, str]],
    output: str,
    func: Callable[..., np.ndarray],
    source: str,
) -> None: ...
def cli_main(args: Sequence[str]) -> int: ...
