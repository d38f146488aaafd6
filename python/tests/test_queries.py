"""Answers: equal to the Rust library's (the `raybatch query` command) bit for bit, the
queries consistent with each other, every kind and thread count alike, Open3D's shapes."""

import sys
import threading
import time

import numpy as np
import pytest

import raybatch
from conftest import BUNNY, cli_query, incoherent

CLI_KINDS = ["bvh8", "bvh4q", "aabb", "zbt"]


@pytest.mark.parametrize("kind", CLI_KINDS)
@pytest.mark.parametrize("batched", [False, True])
def test_answers_equal_the_command_line_bit_for_bit(cli, bunny, rays, tmp_path, kind, batched):
    scene = raybatch.RaycastingScene(kind=kind)
    scene.add_triangles(*bunny)
    flags = ["--tree", kind] + (["--batched"] if batched else [])
    expected = cli_query(cli, BUNNY, rays, "closest", tmp_path, *flags)
    got = scene.cast_rays(rays)
    assert np.array_equal(got["t_hit"].view(np.uint32), expected["t"].view(np.uint32))
    assert np.array_equal(got["primitive_ids"], expected["id"])
    assert np.array_equal(got["primitive_uvs"][:, 0].view(np.uint32), expected["u"].view(np.uint32))
    assert np.array_equal(got["primitive_uvs"][:, 1].view(np.uint32), expected["v"].view(np.uint32))
    hit = expected["id"] != raybatch.INVALID_ID
    assert np.array_equal(got["geometry_ids"], np.where(hit, 0, raybatch.INVALID_ID))
    occluded = cli_query(cli, BUNNY, rays, "any", tmp_path, *flags)
    assert np.array_equal(scene.test_occlusions(rays), occluded)


def test_ranges_equal_the_command_line(cli, bunny_scene, rays, tmp_path):
    expected = cli_query(cli, BUNNY, rays, "closest", tmp_path, tnear=0.2, tfar=0.7)
    got = bunny_scene.cast_rays(rays, tnear=0.2, tfar=0.7)
    assert np.array_equal(got["t_hit"].view(np.uint32), expected["t"].view(np.uint32))
    assert np.array_equal(got["primitive_ids"], expected["id"])


def test_queries_agree_with_each_other(bunny_scene, rays):
    closest = bunny_scene.cast_rays(rays)
    counts = bunny_scene.count_intersections(rays)
    listed = bunny_scene.list_intersections(rays)
    splits = listed["ray_splits"]
    assert counts.dtype == np.int32 and np.array_equal(np.diff(splits), counts)
    assert np.array_equal(bunny_scene.test_occlusions(rays), counts > 0)
    assert np.array_equal(listed["ray_ids"], np.repeat(np.arange(len(rays)), counts))
    first = splits[:-1][counts > 0]
    assert np.array_equal(listed["t_hit"][first], closest["t_hit"][counts > 0])
    assert np.array_equal(listed["primitive_ids"][first], closest["primitive_ids"][counts > 0])
    assert np.array_equal(listed["primitive_uvs"][first], closest["primitive_uvs"][counts > 0])
    # Each ray's hits by t, then id.
    for i in np.flatnonzero(counts > 1)[:200]:
        t = listed["t_hit"][splits[i] : splits[i + 1]]
        assert np.all(np.diff(t) >= 0)
    missed = counts == 0
    assert np.all(np.isinf(closest["t_hit"][missed]))
    assert np.all(closest["geometry_ids"][missed] == raybatch.INVALID_ID)
    assert np.all(closest["primitive_normals"][missed] == 0)


@pytest.mark.parametrize("kind", raybatch.KINDS)
def test_every_kind_and_thread_count_answers_alike(bunny, bunny_scene, rays, kind):
    scene = raybatch.RaycastingScene(1, kind=kind)
    scene.add_triangles(*bunny)
    assert scene.kinds() == [kind]
    reference = bunny_scene.cast_rays(rays, tnear=0.1, tfar=0.9)
    listed = bunny_scene.list_intersections(rays)
    for nthreads in (0, 1, 3):
        got = scene.cast_rays(rays, nthreads, tnear=0.1, tfar=0.9)
        for key in reference:
            assert np.array_equal(got[key], reference[key]), (kind, nthreads, key)
        got = scene.list_intersections(rays, nthreads)
        for key in listed:
            assert np.array_equal(got[key], listed[key]), (kind, nthreads, key)


def test_per_ray_ranges_equal_one_ray_at_a_time(bunny_scene, rays):
    rays = rays[:300]
    rng = np.random.default_rng(5)
    tnear = rng.uniform(0, 0.3, len(rays)).astype(np.float32)
    tfar = (tnear + rng.uniform(0, 1, len(rays))).astype(np.float32)
    batch = bunny_scene.cast_rays(rays, tnear=tnear, tfar=tfar)
    occluded = bunny_scene.test_occlusions(rays, tnear, tfar)
    counts = bunny_scene.count_intersections(rays, tnear=tnear, tfar=tfar)
    for i in range(len(rays)):
        one = bunny_scene.cast_rays(rays[i : i + 1], tnear=tnear[i], tfar=tfar[i])
        assert one["t_hit"][0] == batch["t_hit"][i] or np.isinf(batch["t_hit"][i])
        assert one["primitive_ids"][0] == batch["primitive_ids"][i]
        assert bunny_scene.test_occlusions(rays[i], tnear[i], tfar[i]) == occluded[i]
        assert bunny_scene.count_intersections(rays[i], tnear=tnear[i], tfar=tfar[i]) == counts[i]


def test_answers_keep_the_leading_shape(bunny_scene, rays):
    grid = rays[:24].reshape(2, 3, 4, 6)
    got = bunny_scene.cast_rays(grid)
    assert got["t_hit"].shape == (2, 3, 4)
    assert got["primitive_uvs"].shape == (2, 3, 4, 2)
    assert got["primitive_normals"].shape == (2, 3, 4, 3)
    assert np.array_equal(got["t_hit"].reshape(-1), bunny_scene.cast_rays(rays[:24])["t_hit"])
    assert bunny_scene.test_occlusions(grid).shape == (2, 3, 4)
    assert bunny_scene.count_intersections(grid).shape == (2, 3, 4)
    assert bunny_scene.cast_rays(rays[0])["t_hit"].shape == ()
    assert "primitive_normals" not in bunny_scene.cast_rays(grid, normals=False)


def test_normals_are_the_unit_triangle_normals(bunny, bunny_scene, rays):
    vertices, triangles = bunny
    got = bunny_scene.cast_rays(rays)
    hit = got["primitive_ids"] != raybatch.INVALID_ID
    a, b, c = (vertices[triangles[got["primitive_ids"][hit], k]].astype(np.float64) for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.allclose(got["primitive_normals"][hit], n, atol=1e-6)


def test_two_geometries_answer_as_each_alone(bunny, rays):
    vertices, triangles = bunny
    shifted = vertices + np.float32(0.05)
    both, first, second = (raybatch.RaycastingScene() for _ in range(3))
    assert both.add_triangles(vertices, triangles) == 0
    assert both.add_triangles(shifted, triangles) == 1
    first.add_triangles(vertices, triangles)
    second.add_triangles(shifted, triangles)
    assert both.geometry_count() == 2 and both.triangle_count() == 2 * len(triangles)
    got, a, b = (s.cast_rays(rays) for s in (both, first, second))
    nearer = np.where(b["t_hit"] < a["t_hit"], 1, 0)
    assert np.array_equal(got["t_hit"], np.minimum(a["t_hit"], b["t_hit"]))
    hit = np.isfinite(got["t_hit"])
    assert np.array_equal(got["geometry_ids"][hit], nearer[hit])
    alone = np.where(nearer == 1, b["primitive_ids"], a["primitive_ids"])
    assert np.array_equal(got["primitive_ids"][hit], alone[hit])
    normals = np.where(nearer[:, None] == 1, b["primitive_normals"], a["primitive_normals"])
    assert np.array_equal(got["primitive_normals"][hit], normals[hit])
    listed, la, lb = (s.list_intersections(rays) for s in (both, first, second))
    assert np.array_equal(np.diff(listed["ray_splits"]), np.diff(la["ray_splits"]) + np.diff(lb["ray_splits"]))
    for i in range(0, len(rays), 97):
        s = slice(listed["ray_splits"][i], listed["ray_splits"][i + 1])
        ids = set(zip(listed["geometry_ids"][s].tolist(), listed["primitive_ids"][s].tolist()))
        expect = {(0, p) for p in la["primitive_ids"][la["ray_splits"][i] : la["ray_splits"][i + 1]].tolist()}
        expect |= {(1, p) for p in lb["primitive_ids"][lb["ray_splits"][i] : lb["ray_splits"][i + 1]].tolist()}
        assert ids == expect


def jittered_sphere(n, seed):
    """A closed UV sphere with its vertices pushed in or out at random."""
    rng = np.random.default_rng(seed)
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n + 1)[1:-1], np.linspace(0, 2 * np.pi, 2 * n, endpoint=False), indexing="ij")
    ring = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
    vertices = np.concatenate([ring, [[0, 0, 1], [0, 0, -1]]])
    vertices *= rng.uniform(0.97, 1.03, (len(vertices), 1))
    rows, cols = n - 1, 2 * n
    idx = lambda r, c: r * cols + c % cols
    faces = []
    for r in range(rows - 1):
        for c in range(cols):
            faces += [[idx(r, c), idx(r + 1, c), idx(r + 1, c + 1)], [idx(r, c), idx(r + 1, c + 1), idx(r, c + 1)]]
    top, bottom = len(vertices) - 2, len(vertices) - 1
    for c in range(cols):
        faces += [[top, idx(0, c + 1), idx(0, c)], [bottom, idx(rows - 1, c), idx(rows - 1, c + 1)]]
    return vertices.astype(np.float32), np.array(faces, np.uint32)


def test_no_ray_leaks_out_of_a_closed_jittered_sphere():
    vertices, triangles = jittered_sphere(40, 3)
    scene = raybatch.RaycastingScene()
    scene.add_triangles(vertices, triangles)
    rng = np.random.default_rng(4)
    origins = rng.normal(size=(20000, 3)) * 0.05
    # Aimed at vertices and edge midpoints: the rays that cross shared edges and corners.
    edges = (vertices[triangles[:, 0]] + vertices[triangles[:, 1]]) / 2
    targets = np.concatenate([vertices, edges])[rng.integers(0, len(vertices) + len(edges), 20000)]
    rays = np.concatenate([origins, targets - origins], 1).astype(np.float32)
    assert scene.test_occlusions(rays).all()
    assert np.isfinite(scene.cast_rays(rays)["t_hit"]).all()
    assert (scene.count_intersections(rays) >= 1).all()


def test_an_obj_path_equals_its_arrays(bunny, bunny_scene, rays):
    from_path = raybatch.RaycastingScene()
    assert from_path.add_triangles(BUNNY) == 0
    assert from_path.add_triangles(str(BUNNY)) == 1
    got = from_path.cast_rays(rays)
    assert np.array_equal(got["t_hit"], bunny_scene.cast_rays(rays)["t_hit"])
    assert np.all(got["geometry_ids"][np.isfinite(got["t_hit"])] == 0)  # the first wins ties


def test_a_mesh_object_equals_its_arrays(bunny, bunny_scene, rays):
    class Mesh:
        vertices = bunny[0].astype(np.float64)
        triangles = bunny[1].astype(np.int64)

    scene = raybatch.RaycastingScene()
    scene.add_triangles(Mesh())
    assert np.array_equal(scene.cast_rays(rays)["t_hit"], bunny_scene.cast_rays(rays)["t_hit"])


def test_an_empty_scene_misses_everything(rays):
    scene = raybatch.RaycastingScene()
    assert scene.geometry_count() == 0 and scene.kinds() == []
    got = scene.cast_rays(rays)
    assert np.all(np.isinf(got["t_hit"])) and np.all(got["primitive_ids"] == raybatch.INVALID_ID)
    assert not scene.test_occlusions(rays).any()
    assert scene.list_intersections(rays)["ray_splits"].tolist() == [0] * (len(rays) + 1)
    empty = raybatch.RaycastingScene()
    empty.add_triangles(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64))
    assert not empty.test_occlusions(rays).any()
    assert bunny_scene_zero_rays_ok(empty)


def bunny_scene_zero_rays_ok(scene):
    none = np.zeros((0, 6), np.float32)
    return scene.cast_rays(none)["t_hit"].shape == (0,) and scene.list_intersections(none)["ray_splits"].tolist() == [0]


def test_contiguous_rays_are_read_in_place(bunny_scene, bunny):
    import tracemalloc

    rays = incoherent(bunny[0], 200_000, 9)
    bunny_scene.test_occlusions(rays[:10])
    tracemalloc.start()
    try:
        bunny_scene.test_occlusions(rays)
        bunny_scene.cast_rays(rays)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < rays.nbytes / 4, peak
    # Unaligned and strided rays are copied, with the same answers.
    buffer = np.zeros(rays.nbytes + 1, np.uint8)
    unaligned = buffer[1:].view(np.float32).reshape(rays.shape)
    unaligned[:] = rays
    assert not unaligned.flags.aligned
    assert np.array_equal(bunny_scene.test_occlusions(unaligned), bunny_scene.test_occlusions(rays))
    strided = np.repeat(rays, 2, axis=0)[::2]
    assert np.array_equal(bunny_scene.test_occlusions(strided), bunny_scene.test_occlusions(rays))


def test_queries_release_the_gil(bunny_scene, bunny):
    """Another Python thread runs while a query runs: with a switch interval far longer than
    the test, the thread can only run when the query gives the GIL up."""
    rays = incoherent(bunny[0], 400_000, 10)
    steps, stop = [0], threading.Event()

    def count():
        while not stop.is_set():
            steps[0] += 1
            time.sleep(1e-6)  # gives the GIL up between steps

    interval = sys.getswitchinterval()
    thread = threading.Thread(target=count)
    thread.start()
    try:
        sys.setswitchinterval(1000.0)
        time.sleep(0.01)
        before = steps[0]
        bunny_scene.cast_rays(rays)
        after = steps[0]
    finally:
        sys.setswitchinterval(interval)
        stop.set()
        thread.join()
    assert after > before


def test_threads_share_a_scene(bunny_scene, rays):
    expected = bunny_scene.cast_rays(rays)["t_hit"]
    answers = [None] * 4

    def work(i):
        answers[i] = bunny_scene.cast_rays(rays, [1, 2, 2, 3][i])["t_hit"]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(np.array_equal(a, expected) for a in answers)
