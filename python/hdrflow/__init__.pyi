"""Type stub of ``hdrflow``, the public Python API (``__init__.py`` has the documentation).

``tests/test_typing.py`` checks that it parses and that every public name and parameter of the
package is declared here.
"""

import os
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, TypeVar, Union


from ._hdrflow import PipelineError as PipelineError
from ._hdrflow import RunError as RunError

__all__ = ["run", "batch", "op", "ops", "operator", "Result", "Ron", "PipelineError", "RunError", "value_types"]

_Path = Union[str, "os.PathLike[str]"]
_F = TypeVar("_F", bound=Callable[..., Any])

class Ron(str):
    """Raw RON text for ``set=``, passed as written."""

class Result(Mapping[str, Any]):
    """A finished run: values by ``"node"`` (default port) and ``"node.port"`` (other ports)."""

    report: Dict[str, Any]
    def __init__(self, values: Dict[str, Any], report: Dict[str, Any], channels: Dict[str, List[str]]) -> None: ...
    def __getitem__(self, key: str) -> Any: ...
    def __iter__(self) -> Iterator[str]: ...
    def __len__(self) -> int: ...
    def __contains__(self, key: object) -> bool: ...
    def channels(self, key: str) -> List[str]: ...
    def status(self, node: str) -> str: ...

def run(
    pipeline: _Path,
    set: Optional[Mapping[str, Any]] = None,
    targets: Optional[Sequence[str]] = None,
    out: Optional[_Path] = None,
    cache_dir: Optional[_Path] = None,
    jobs: Optional[int] = None,
    inputs: Optional[Mapping[str, Any]] = None,
    no_cache: bool = False,
) -> Result: ...
def batch(
    graph: _Path,
    over: Any = None,
    sweep: Any = None,
    out: _Path = "out",
    jobs: Optional[int] = None,
    cache_dir: Optional[_Path] = None,
    keep_going: bool = False,
    zip: bool = False,
    item_dir: Optional[str] = None,
) -> List[Dict[str, Any]]: ...
def ops() -> List[Dict[str, Any]]: ...
def value_types() -> List[str]: ...
def op(
    name: str,
    /,
    *,
    cache_dir: Optional[_Path] = None,
    no_cache: bool = False,
    **fields: Any,
) -> Any: ...
def operator(
    name: str,
    fields: Mapping[str, Any],
    output: str = "image",
    version: int = 1,
    doc: Optional[str] = None,
    category: str = "python",
) -> Callable[[_F], _F]: ...
