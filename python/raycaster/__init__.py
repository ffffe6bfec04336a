"""MIT 6.837's scenes rendered by the raycaster: the GPU kernel, or its f64 reference, into
numpy arrays.

    import raycaster
    scene = raycaster.Scene.from_file("scene4_05_transparent_bar.txt")
    out = raycaster.render(scene, 200, 200, shadows=True, bounces=5, weight=0.01)
    out["color8"]   # uint8, 200 x 200 x 3: the bytes of -output out.tga

``render`` renders into arrays, ``compare`` holds the GPU against the reference (the
``compare`` command), ``run`` runs a course command line as the ``raycaster`` binary does.
The repository's docs/python.md has the details.
"""

from __future__ import annotations

import os
import shlex
import warnings
from typing import Any, Dict, Iterable, Optional, Sequence, Tuple, Union

from . import _raycaster
from ._raycaster import CommandError, GpuError, Scene, SceneError, SceneWarning

__all__ = [
    "Scene",
    "SceneError",
    "SceneWarning",
    "GpuError",
    "CommandError",
    "render",
    "compare",
    "run",
]
__version__ = _raycaster.__version__

PathLike = Union[str, "os.PathLike[str]"]


def _keywords(outputs, shade_back, specular_fix, shadows, bounces, weight, samples, sampler,
              filter, seed, grid, visualize_grid, stats, triangle_test, sphere_test):
    # One dict for the native module, which turns each keyword into its course flag.
    if isinstance(outputs, str):
        outputs = (outputs,)
    return {
        "outputs": list(outputs),
        "shade_back": shade_back,
        "specular_fix": specular_fix,
        "shadows": shadows,
        "bounces": bounces,
        "weight": weight,
        "samples": samples,
        "sampler": sampler,
        "filter": None if filter is None else (filter[0], float(filter[1])),
        "seed": seed,
        "grid": None if grid is None else tuple(grid),
        "visualize_grid": visualize_grid,
        "stats": stats,
        "triangle_test": triangle_test,
        "sphere_test": sphere_test,
    }


def render(
    scene: Scene,
    width: int,
    height: int,
    *,
    outputs: Iterable[str] = ("color", "normals", "depth"),
    shade_back: bool = False,
    shadows: bool = False,
    bounces: int = 0,
    weight: float = 0.0,
    samples: Optional[int] = None,
    sampler: str = "uniform",
    filter: Optional[Tuple[str, float]] = None,
    seed: int = 0,
    grid: Optional[Tuple[int, int, int]] = None,
    visualize_grid: bool = False,
    stats: bool = False,
    specular_fix: bool = False,
    triangle_test: str = "watertight",
    sphere_test: str = "robust",
    backend: str = "auto",
) -> Dict[str, Any]:
    """Render ``scene`` at ``width`` x ``height`` pixels into numpy arrays.

    The keywords are the course's flags: ``shade_back`` is ``-shade_back``, ``shadows``
    ``-shadows``, ``bounces``/``weight`` ``-bounces N -weight W``, ``samples=16,
    sampler="jittered"`` ``-jittered_samples 16``, ``filter=("tent", 1.5)``
    ``-tent_filter 1.5``, ``seed`` ``--seed``, ``grid=(10, 10, 10)`` ``-grid 10 10 10``,
    ``visualize_grid`` ``-visualize_grid``, ``stats`` ``-stats``, ``specular_fix``
    ``--specular-fix``, ``triangle_test``/``sphere_test`` the GPU's tests. A value the
    command line refuses raises ValueError with the command line's message.

    ``outputs`` names what to compute, among "color", "normals" and "depth".

    ``backend``: "gpu" (the f32 kernel; a scene it cannot render faithfully raises
    GpuError), "cpu" (the f64 reference) or "auto" (the GPU, and the reference for what the
    GPU refuses or would render slower; when it hands a scene over, or no GPU opens, a
    UserWarning says why). A backend's device opens once per process.

    Returns a dict, pixel rows from the top of the image:

    - ``color``: float32, H x W x 3, linear and unclamped (background where nothing is hit);
    - ``color8``: uint8, H x W x 3, quantised exactly as the image files (-output x.tga);
    - ``normals``: float32, H x W x 3, the unit world normal, 0 where nothing is hit;
    - ``depth``: float32, H x W, the hit's t, inf where nothing is hit (as -depth x.exr);
    - ``hit``: bool, H x W;
    - ``stats``: dict: tiles, kernel_ms, prepare_ms, acceleration, and with ``stats=True``
      the course's counts (non_shadow_rays, shadow_rays, intersections, cells_traversed);
    - ``backend``: who rendered, in words.

    The GIL is released while rendering; Ctrl-C stops the render between two tiles
    (KeyboardInterrupt).
    """
    keywords = _keywords(outputs, shade_back, specular_fix, shadows, bounces, weight, samples,
                         sampler, filter, seed, grid, visualize_grid, stats, triangle_test,
                         sphere_test)
    arrays, notice = _raycaster.render(scene, width, height, backend, keywords)
    if notice is not None:
        warnings.warn(notice, UserWarning, stacklevel=2)
    return arrays


def compare(
    scene: Scene,
    width: int,
    height: int,
    *,
    outputs: Iterable[str] = ("color", "normals", "depth"),
    depth_range: Optional[Tuple[float, float]] = None,
    shade_back: bool = False,
    shadows: bool = False,
    bounces: int = 0,
    weight: float = 0.0,
    samples: Optional[int] = None,
    sampler: str = "uniform",
    filter: Optional[Tuple[str, float]] = None,
    seed: int = 0,
    grid: Optional[Tuple[int, int, int]] = None,
    specular_fix: bool = False,
    triangle_test: str = "watertight",
    sphere_test: str = "robust",
) -> Dict[str, Any]:
    """The GPU against the f64 reference, as the ``compare`` command measures it.

    Renders ``scene`` on the GPU (GpuError if there is none, or if it refuses the scene) and
    with the reference, with the keywords of ``render``. ``depth_range`` is ``-depth MIN
    MAX``'s range for the 8-bit depth image (default: the reference's range of hits).

    Returns a dict: for each output ("color", "normals", "depth") a dict of ``pixels``,
    ``off_by_more_than_one`` (pixels with a channel more than one level off),
    ``max_level_diff``, ``mean_level_diff``, ``hit_mismatches``, ``float_max``,
    ``float_mean``, ``relative_max`` (depth) and ``non_finite``; ``table``, the Markdown
    table the command prints; ``gpu``, the adapter's name; ``passed`` and ``verdict``: the
    command's verdict (at most 0.1 % of the pixels more than one level off, no NaN) and its
    message when it fails.
    """
    keywords = _keywords(outputs, shade_back, specular_fix, shadows, bounces, weight, samples,
                         sampler, filter, seed, grid, False, False, triangle_test, sphere_test)
    return _raycaster.compare(scene, width, height, depth_range, keywords)


def run(command_line: Union[str, Sequence[str]], cwd: Optional[PathLike] = None) -> None:
    """Run a course command line as the ``raycaster`` binary runs it, in this process.

    ``command_line`` is the words after the program's name, as one string (split as a
    shell splits it) or a list: ``run("-input scene4_05.txt -size 200 200 -output o.tga
    -shadows", cwd="a4")``. A leading ``raycaster`` is dropped. Every command works
    (``batch commands.txt``, ``compare``, ``grade``...); the files are the binary's, byte for
    byte: it is the binary's code. Relative paths are read from ``cwd`` (default: the
    working folder); while a command line with ``cwd`` runs, it is the process's working
    folder.

    Raises CommandError (``.status``: 2 for a bad command line, 1 for a failed one) with the
    message the binary prints. What the binary prints besides (warnings, notes, -stats,
    compare's table) goes to this process's stderr and stdout file descriptors, as the
    binary's would. The GIL is released; Ctrl-C is seen when the command line has ended.
    """
    words = shlex.split(command_line) if isinstance(command_line, str) else list(command_line)
    if words[:1] == ["raycaster"]:
        words = words[1:]
    _raycaster.run([os.fspath(w) for w in words], None if cwd is None else os.fspath(cwd))
