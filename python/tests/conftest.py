"""What the package's tests need besides the package: the `raycaster` binary (whose files are
the independent path the arrays are held to), the course's files and a GPU.

tests/python.rs (cargo test) runs these with RAYCASTER_BIN set to the binary cargo built; run
by hand, the release binary of the repository is used."""

import os
import pathlib
import subprocess

import pytest

import raycaster

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def binary():
    path = pathlib.Path(os.environ.get("RAYCASTER_BIN", REPOSITORY / "target" / "release" / "raycaster"))
    if not path.exists():
        pytest.fail(f"{path}: no raycaster binary (cargo build --release, or set RAYCASTER_BIN)")
    return path


@pytest.fixture(scope="session")
def run_binary(binary):
    """The binary on a command line in `cwd`: (status, stdout, stderr)."""

    def run(words, cwd):
        done = subprocess.run([str(binary), *words], cwd=cwd, capture_output=True, text=True)
        return done.returncode, done.stdout, done.stderr

    return run


@pytest.fixture(scope="session")
def corpus():
    """Assignment 4's folder, as the Rust tests find it (RAYCASTER_CORPUS, else
    ../shared/mit6837 beside the repository)."""
    root = pathlib.Path(os.environ.get("RAYCASTER_CORPUS", REPOSITORY.parent / "shared" / "mit6837"))
    if not (root / "a4" / "commands.txt").exists():
        if os.environ.get("RAYCASTER_REQUIRE_CORPUS") == "1":
            pytest.fail(f"{root}: the course's files are missing and RAYCASTER_REQUIRE_CORPUS=1")
        pytest.skip(f"{root}: the course's files are missing (README: the course's files)")
    return root


@pytest.fixture(scope="session")
def gpu():
    """Whether the GPU backend opens: the GPU's tests fail loudly without one, unless
    RAYCASTER_SKIP_GPU=1 skips them on purpose."""
    tiny = raycaster.Scene.from_text(SPHERE)
    try:
        raycaster.render(tiny, 4, 4, backend="gpu")
    except raycaster.GpuError as e:
        if os.environ.get("RAYCASTER_SKIP_GPU") == "1":
            pytest.skip(f"no GPU ({e}); RAYCASTER_SKIP_GPU=1")
        pytest.fail(f"no GPU: {e} (RAYCASTER_SKIP_GPU=1 skips the GPU's tests on purpose)")


# A unit sphere at the origin seen by an orthographic camera (tests/renderer.rs's scene).
SPHERE = """OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }
Lights { numLights 1 DirectionalLight { direction -0.3 -0.5 -1 color 0.9 0.9 0.9 } }
Background { color 0.25 0.25 0.25 ambientLight 0.15 0.15 0.15 }
Materials { numMaterials 1 Material { diffuseColor 1 0.2 0.2 } }
Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }
"""
