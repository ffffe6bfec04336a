# The native module (python/src/). raycaster/__init__.py wraps render, compare and run with
# their keywords and docstrings; Scene and the exceptions are used as they are.
from __future__ import annotations

import os
import pathlib
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

__version__: str

class SceneError(ValueError):
    """A scene (or one of its OBJ meshes) that cannot be read; str(e) is FILE:LINE:COLUMN: MESSAGE."""

    file: str
    line: Optional[int]
    column: Optional[int]
    message: str

class SceneWarning(UserWarning):
    """A remark about a scene that still renders, located as the command line locates it."""

class GpuError(RuntimeError):
    """The GPU could not render (no device, a scene the f32 kernel refuses, a lost device)."""

class CommandError(RuntimeError):
    """A failed command line of raycaster.run; status is the binary's exit status."""

    status: int

class Scene:
    """A parsed scene; render it any number of times."""

    @staticmethod
    def from_file(path: Union[str, os.PathLike[str]]) -> Scene:
        """Read a scene file and the OBJ meshes it names, as -input does."""
    @staticmethod
    def from_text(
        text: str,
        obj_files: Optional[Mapping[str, str]] = None,
        path: Union[str, os.PathLike[str]] = "scene.txt",
    ) -> Scene:
        """Parse scene text named ``path``; obj_files maps each obj_file name to its text."""
    @property
    def path(self) -> pathlib.Path: ...
    @property
    def warnings(self) -> List[str]: ...

def render(
    scene: Scene, width: int, height: int, backend: str, keywords: Mapping[str, Any]
) -> Tuple[Dict[str, Any], Optional[str]]: ...
def compare(
    scene: Scene,
    width: int,
    height: int,
    depth_range: Optional[Tuple[float, float]],
    keywords: Mapping[str, Any],
) -> Dict[str, Any]: ...
def run(args: List[str], cwd: Optional[str] = None) -> None: ...
