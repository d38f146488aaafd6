"""Every bad input is a ValueError with the library's message (an OSError for files), never a
crash, and a failed add leaves the scene as it was."""

import numpy as np
import pytest

import raybatch

TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
FACES = np.array([[0, 1, 2]], np.uint32)
RAY = np.array([[0.2, 0.2, 1, 0, 0, -1]], np.float32)


@pytest.fixture
def scene():
    scene = raybatch.RaycastingScene()
    scene.add_triangles(TRIANGLE, FACES)
    return scene


@pytest.mark.parametrize(
    "vertices, faces, message",
    [
        (TRIANGLE.astype(np.float64), FACES, "float32"),
        (TRIANGLE[:, :2].copy(), FACES, r"shape \(V, 3\)"),
        (TRIANGLE, FACES.astype(np.float32), "integers"),
        (TRIANGLE, FACES[:, :2].copy(), r"shape \(F, 3\)"),
        (TRIANGLE, np.array([[0, 1, -1]]), "negative"),
        (TRIANGLE, np.array([[0, 1, 1 << 33]]), "32 bits"),
        (TRIANGLE, np.array([[0, 1, 3]]), "triangle 0 uses vertex 3, but the mesh has 3 vertices"),
        (np.where(np.eye(3, dtype=bool), np.nan, TRIANGLE).astype(np.float32), FACES, "vertex 0 has a NaN"),
        (TRIANGLE + np.float32(np.inf), FACES, "NaN or infinite"),
        (TRIANGLE * np.float32(1e13), FACES, "larger than"),
    ],
)
def test_bad_meshes_are_value_errors_and_change_nothing(scene, vertices, faces, message):
    with pytest.raises(ValueError, match=message):
        scene.add_triangles(vertices, faces)
    assert scene.geometry_count() == 1
    assert scene.test_occlusions(RAY).tolist() == [True]


@pytest.mark.parametrize(
    "rays, message",
    [
        (RAY.astype(np.float64), "float32"),
        (RAY[:, :5].copy(), r"shape \(\.\.\., 6\)"),
        (np.float32(1), r"shape \(\.\.\., 6\)"),
        (np.array([[0, 0, 1, 0, 0, -1]] * 3 + [[np.nan, 0, 1, 0, 0, -1]], np.float32), "ray 3: ray origin is NaN or infinite"),
        (np.array([[0, 0, 1, np.inf, 0, -1]], np.float32), "ray 0: ray direction is NaN or infinite"),
        (np.array([[0, 0, 1, 0, 0, 0]], np.float32), "ray 0: ray direction is zero"),
    ],
)
@pytest.mark.parametrize("query", ["cast_rays", "test_occlusions", "count_intersections", "list_intersections"])
def test_bad_rays_are_value_errors(scene, rays, message, query):
    with pytest.raises(ValueError, match=message):
        getattr(scene, query)(rays)


@pytest.mark.parametrize("nthreads", [1, 2])
@pytest.mark.parametrize("query", ["cast_rays", "test_occlusions", "count_intersections", "list_intersections"])
def test_the_first_bad_ray_is_named_whatever_the_thread_that_meets_it(scene, query, nthreads):
    rays = np.repeat(RAY, 200_000, axis=0)
    rays[150_000, 0] = np.nan
    rays[70_001, 5] = 0.0
    rays[70_001, 3:5] = 0.0
    with pytest.raises(ValueError, match="ray 70001: ray direction is zero"):
        getattr(scene, query)(rays, nthreads=nthreads)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"tnear": -1.0}, "ray 0: ray range is empty, negative or NaN"),
        ({"tnear": 2.0, "tfar": 1.0}, "ray 0: ray range"),
        ({"tfar": float("nan")}, "ray 0: ray range"),
        ({"tnear": np.zeros(2, np.float32)}, r"tnear must be a number or of shape \(1,\)"),
        ({"tfar": np.zeros(1, np.int32)}, "tfar must be a number or a float array"),
        ({"tfar": "far"}, "tfar must be a number or a float array"),
        ({"nthreads": -1}, "nthreads must be >= 0"),
        ({"nthreads": True}, "nthreads must be an int"),
        ({"nthreads": 1.5}, "nthreads must be an int"),
        ({"nthreads": 1 << 20}, "per core"),
    ],
)
def test_bad_options_are_value_errors(scene, options, message):
    with pytest.raises(ValueError, match=message):
        scene.cast_rays(RAY, **options)


def test_bad_scene_arguments_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match='unknown structure kind "octree"'):
        raybatch.RaycastingScene(kind="octree")
    with pytest.raises(ValueError, match="kind must be a name"):
        raybatch.RaycastingScene(kind=3)
    with pytest.raises(ValueError, match="nthreads"):
        raybatch.RaycastingScene(-2)
    with pytest.raises(ValueError, match="arrays, a mesh or an OBJ path"):
        raybatch.RaycastingScene().add_triangles(3)


def test_bad_obj_files_are_value_errors_and_missing_ones_os_errors(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    scene = raybatch.RaycastingScene()
    with pytest.raises(ValueError, match="bad OBJ file"):
        scene.add_triangles(bad)
    with pytest.raises(ValueError, match="bad OBJ file"):
        raybatch.read_obj(bad)
    with pytest.raises(OSError, match="cannot read"):
        scene.add_triangles(tmp_path / "missing.obj")
    with pytest.raises(OSError, match="cannot read"):
        raybatch.read_obj(tmp_path / "missing.obj")
    assert scene.geometry_count() == 0
