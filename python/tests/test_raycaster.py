"""The package as its users use it, held to the binary's own files: the arrays equal the
images it writes byte for byte and its EXR floats to the bit, on both backends."""

import os
import signal
import sys
import threading
import time
import warnings

import numpy as np
import OpenEXR
import pytest
from PIL import Image

import raycaster
from conftest import SPHERE

# Course lines of assignment 4: refraction ten deep, a mesh with reflections, a point light.
LINES = {
    "transparent_bar": ("scene4_05_transparent_bar.txt", ["-shadows", "-bounces", "10", "-weight", "0.01", "-shade_back"],
                        dict(shadows=True, bounces=10, weight=0.01, shade_back=True)),
    "faceted_gem": ("scene4_14_faceted_gem.txt", ["-shadows", "-shade_back", "-bounces", "2", "-weight", "0.01"],
                    dict(shadows=True, shade_back=True, bounces=2, weight=0.01)),
    "point_light": ("scene4_10_point_light_distance.txt", ["-shadows"], dict(shadows=True)),
}
SIZE = (160, 120)
DEPTH_RANGE = ("8", "14")


def image(path):
    return np.asarray(Image.open(path).convert("RGB"))


def exr(path, channel):
    return OpenEXR.File(str(path)).channels()[channel].pixels


def levels(values):
    """docs/SPEC.md §5's quantisation, floor(255 * clamp(v, 0, 1)), in float32 as the files'."""
    return np.floor(np.float32(255) * np.clip(values, np.float32(0), np.float32(1))).astype(np.uint8)


@pytest.fixture(params=["gpu", "cpu"])
def backend(request):
    if request.param == "gpu":
        request.getfixturevalue("gpu")
    return request.param


@pytest.mark.parametrize("line", LINES)
def test_arrays_are_the_binarys_images_and_floats(line, backend, corpus, run_binary, tmp_path):
    name, flags, keywords = LINES[line]
    scene_path = corpus / "a4" / name
    size = ["-size", str(SIZE[0]), str(SIZE[1])]
    common = ["-input", str(scene_path), *size, *flags, "--backend", backend]
    status, _, err = run_binary([*common, "-output", "c.tga", "-normals", "n.png", "-depth", *DEPTH_RANGE, "d.tga"],
                                tmp_path)
    assert status == 0, err
    status, _, err = run_binary([*common, "-output", "c.exr", "-normals", "n.exr", "-depth", *DEPTH_RANGE, "d.exr"],
                                tmp_path)
    assert status == 0, err

    out = raycaster.render(raycaster.Scene.from_file(scene_path), *SIZE, backend=backend, **keywords)

    assert out["backend"].startswith(backend)
    assert out["color8"].dtype == np.uint8 and out["color8"].shape == (SIZE[1], SIZE[0], 3)
    np.testing.assert_array_equal(out["color8"], image(tmp_path / "c.tga"))
    np.testing.assert_array_equal(out["color"], exr(tmp_path / "c.exr", "RGB"))
    np.testing.assert_array_equal(out["normals"], exr(tmp_path / "n.exr", "RGB"))
    np.testing.assert_array_equal(out["depth"], exr(tmp_path / "d.exr", "Z"))
    assert np.isinf(out["depth"][~out["hit"]]).all() and np.isfinite(out["depth"][out["hit"]]).all()
    # The 8-bit normal and depth images from the arrays, as docs/SPEC.md §5 defines them.
    normals8 = np.where(out["hit"][..., None], levels(np.abs(out["normals"])), 0)
    np.testing.assert_array_equal(normals8, image(tmp_path / "n.png"))
    lo, hi = (float(v) for v in DEPTH_RANGE)
    grey = ((hi - out["depth"].astype(np.float64)) / (hi - lo)).astype(np.float32)
    depth8 = np.where(out["hit"], levels(np.where(out["hit"], grey, 0)), 0)
    np.testing.assert_array_equal(depth8, image(tmp_path / "d.tga")[..., 0])


def test_stats_are_the_courses_counts(corpus, run_binary, tmp_path):
    name, flags, keywords = LINES["transparent_bar"]
    status, stdout, err = run_binary(["-input", str(corpus / "a4" / name), "-size", "50", "40", "-output", "c.tga",
                                      *flags, "-stats", "--backend", "cpu"], tmp_path)
    assert status == 0, err
    out = raycaster.render(raycaster.Scene.from_file(corpus / "a4" / name), 50, 40, backend="cpu", stats=True,
                           **keywords)
    assert out["stats"]["shadow_rays"] > 0
    for key, label in [("non_shadow_rays", "num non-shadow rays"), ("shadow_rays", "num shadow rays"),
                       ("intersections", "total intersections"), ("cells_traversed", "total cells traversed")]:
        line = next(line for line in stdout.splitlines() if line.strip().startswith(label))
        assert int(line.split()[-1]) == out["stats"][key], line


BAD = """OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }
Background { color 0 0 0 }
Materials { numMaterials 1 Material { diffuseColor 1 0.2 0.2 } }
Group { numObjects 1 MaterialIndex 0
    Sphere { center 0 0 zero radius 1 } }
"""


def test_a_bad_scene_raises_scene_error_where_the_command_line_says(run_binary, tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text(BAD)
    line = 5
    column = BAD.splitlines()[line - 1].index("zero") + 1
    with pytest.raises(raycaster.SceneError) as caught:
        raycaster.Scene.from_file(path)
    e = caught.value
    assert (e.file, e.line, e.column) == (str(path), line, column)
    status, _, err = run_binary(["-input", str(path), "-size", "8", "8", "-output", "o.tga"], tmp_path)
    assert status == 1
    assert err.strip() == f"raycaster: {e}"
    assert str(e) == f"{path}:{line}:{column}: {e.message}"
    with pytest.raises(raycaster.SceneError) as caught:
        raycaster.Scene.from_text(BAD, path="mine.txt")
    assert (caught.value.file, caught.value.line, caught.value.column) == ("mine.txt", line, column)


def test_obj_files_from_memory_render_as_from_disk(corpus):
    folder = corpus / "a4"
    text = (folder / "scene4_14_faceted_gem.txt").read_text()
    meshes = {name: (folder / name).read_text() for name in ["diamond.obj"] if name in text}
    assert meshes, "the gem's scene names diamond.obj"
    from_text = raycaster.Scene.from_text(text, obj_files=meshes)
    from_file = raycaster.Scene.from_file(folder / "scene4_14_faceted_gem.txt")
    a = raycaster.render(from_text, 40, 40, backend="cpu")
    b = raycaster.render(from_file, 40, 40, backend="cpu")
    np.testing.assert_array_equal(a["color"], b["color"])
    with pytest.raises(raycaster.SceneError) as caught:
        raycaster.Scene.from_text(text, obj_files={})
    assert caught.value.line is not None, "the obj_file line of the scene"


def test_keywords_the_command_line_refuses_raise_its_message():
    scene = raycaster.Scene.from_text(SPHERE)
    with pytest.raises(ValueError, match="-jittered_samples: 8 is not a square number"):
        raycaster.render(scene, 8, 8, samples=8, sampler="jittered")
    with pytest.raises(ValueError, match="-visualize_grid draws the grid's cells"):
        raycaster.render(scene, 8, 8, visualize_grid=True)
    with pytest.raises(ValueError, match="backend"):
        raycaster.render(scene, 8, 8, backend="tpu")


def test_outputs_not_asked_for_are_not_returned():
    out = raycaster.render(raycaster.Scene.from_text(SPHERE), 8, 6, outputs=("depth",), backend="cpu")
    assert set(out) == {"depth", "hit", "stats", "backend"}
    assert out["depth"].shape == (6, 8) and out["hit"].shape == (6, 8)


def test_the_gil_is_released_while_rendering(corpus):
    """With a switch interval of minutes, a thread runs while the main thread holds the GIL
    only if the main thread lets go of it: the counter moves during the render only if the
    render released it."""
    scene = raycaster.Scene.from_file(corpus / "a4" / "scene4_05_transparent_bar.txt")
    count = 0
    stop = threading.Event()

    def counter():
        nonlocal count
        while not stop.is_set():
            count += 1
            time.sleep(0)  # lets go of the GIL, so that the main thread can take it

    interval = sys.getswitchinterval()
    sys.setswitchinterval(300)
    thread = threading.Thread(target=counter)
    try:
        thread.start()
        while count == 0:
            threading.Event().wait(0.001)
        before = count
        raycaster.render(scene, 200, 200, backend="cpu", shadows=True, bounces=10, weight=0.01, shade_back=True)
        after = count
    finally:
        stop.set()
        sys.setswitchinterval(interval)
        thread.join()
    assert after > before, "no Python thread ran during the render"


def test_ctrl_c_stops_a_render_between_tiles(corpus):
    """SIGINT while the reference renders a large image: KeyboardInterrupt, well before the
    image's last tile (the render would take many seconds)."""
    scene = raycaster.Scene.from_file(corpus / "a4" / "scene4_05_transparent_bar.txt")
    # Python's own Ctrl-C handler, whatever this process inherited: a process started in the
    # background by a shell without job control starts with SIGINT ignored, and Python then
    # installs no handler.
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            raycaster.render(scene, 2000, 2000, backend="cpu", shadows=True, bounces=10, weight=0.01,
                             shade_back=True)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, inherited)


# A field of tiny spheres, every coordinate scaled by 1e30: out of the f32 kernel's range, and
# enough primitives at 200² that `auto` opens the GPU rather than giving the job to the
# reference for being small (src/renderer/auto.rs).
def far_spheres(n=64, scale=1e30):
    spheres = "".join(f"Sphere {{ center {(i % 8 - 3.5) * 0.3 * scale} {(i // 8 - 3.5) * 0.3 * scale} 0 "
                      f"radius {0.1 * scale} }}\n" for i in range(n))
    return (f"OrthographicCamera {{ center 0 0 {10 * scale} direction 0 0 -1 up 0 1 0 size {3 * scale} }}\n"
            "Lights { numLights 1 DirectionalLight { direction -0.3 -0.5 -1 color 0.9 0.9 0.9 } }\n"
            "Background { color 0.25 0.25 0.25 ambientLight 0.15 0.15 0.15 }\n"
            "Materials { numMaterials 1 Material { diffuseColor 1 0.2 0.2 } }\n"
            f"Group {{ numObjects {n} MaterialIndex 0\n{spheres}}}\n")


def test_auto_falls_back_with_a_python_warning(gpu):
    scene = raycaster.Scene.from_text(far_spheres())
    with pytest.warns(UserWarning, match="rendering with the f64 CPU reference instead") as caught:
        out = raycaster.render(scene, 200, 200, backend="auto")
    assert "f32" in str(caught[0].message)
    assert out["backend"].startswith("cpu")
    reference = raycaster.render(scene, 200, 200, backend="cpu")
    np.testing.assert_array_equal(out["color8"], reference["color8"])
    assert out["hit"].any()
    with pytest.raises(raycaster.GpuError, match="f32"):
        raycaster.render(scene, 200, 200, backend="gpu")


def test_a_scene_in_range_renders_without_a_warning(gpu):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = raycaster.render(raycaster.Scene.from_text(far_spheres(scale=1)), 200, 200, backend="auto")
    assert out["backend"].startswith("gpu")


def test_run_writes_the_binarys_bytes(corpus, run_binary, tmp_path):
    lines = [line.split() for line in (corpus / "a4" / "commands.txt").read_text().splitlines()[:5]]
    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    for folder in (ours, theirs):
        folder.mkdir()
    for words in lines:
        words = [str(corpus / "a4" / w) if w.endswith(".txt") else w for w in words]
        raycaster.run(words, cwd=ours)
        status, _, err = run_binary(words, theirs)
        assert status == 0, err
    written = sorted(p.name for p in ours.iterdir())
    assert written == sorted(p.name for p in theirs.iterdir()) and len(written) == 5
    for name in written:
        assert (ours / name).read_bytes() == (theirs / name).read_bytes(), name


def test_run_reads_a_string_and_fails_as_the_binary(run_binary, tmp_path):
    with pytest.raises(raycaster.CommandError) as caught:
        raycaster.run("raycaster -input nowhere.txt -size 8 8 -output o.tga -shadow", cwd=tmp_path)
    status, _, err = run_binary(["-input", "nowhere.txt", "-size", "8", "8", "-output", "o.tga", "-shadow"],
                                tmp_path)
    assert caught.value.status == status == 2
    assert err.strip() == f"raycaster: {caught.value}"
    assert os.getcwd() != str(tmp_path)


def test_compare_is_the_commands_table(gpu, corpus, run_binary, tmp_path):
    name, flags, keywords = LINES["faceted_gem"]
    words = ["compare", "--outputs", "color,normals,depth", "-input", str(corpus / "a4" / name), "-size", "64", "48"]
    status, stdout, err = run_binary([*words, *flags], tmp_path)
    result = raycaster.compare(raycaster.Scene.from_file(corpus / "a4" / name), 64, 48, **keywords)
    table = stdout[stdout.index("| output"):]
    assert table == result["table"]
    assert result["passed"] == (status == 0), err
    assert result["color"]["pixels"] == 64 * 48
