"""The Dask path on a LocalCluster of two workers gives one process's answers; a scene
travels once per client and each worker loads it once."""

import subprocess
import sys

import numpy as np
import pytest

import raybatch
from conftest import ROOT
from test_cooked import QUERIES

distributed = pytest.importorskip("distributed")
da = pytest.importorskip("dask.array")
from raybatch import dask as rbdask  # noqa: E402


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        with distributed.Client(cluster) as client:
            yield client


def assert_equal(a, b):
    if isinstance(b, dict):
        assert a.keys() == b.keys()
        for key in b:
            assert np.array_equal(a[key], b[key]), key
    else:
        assert np.array_equal(a, b)


@pytest.mark.parametrize("query", QUERIES)
def test_numpy_and_dask_rays_answer_as_one_process(client, bunny_scene, rays, query):
    expected = getattr(bunny_scene, query)(rays)
    assert_equal(rbdask.trace(bunny_scene, rays, query, client=client, chunk_rays=700), expected)
    lazy = da.from_array(rays, chunks=(900, 6))
    assert_equal(rbdask.trace(bunny_scene, lazy, query, client=client, chunk_rays=1100), expected)


def test_paths_bytes_options_and_shapes(client, bunny_scene, rays, tmp_path):
    path = tmp_path / "bunny.rbt"
    bunny_scene.save(path)
    grid = rays.reshape(40, 100, 6)
    expected = bunny_scene.cast_rays(grid, tfar=0.5, normals=False)
    for scene in (path, str(path), bunny_scene.to_bytes()):
        got = rbdask.trace(scene, grid, "cast_rays", client=client, chunk_rays=1000, tfar=0.5, normals=False)
        assert_equal(got, expected)
    none = rbdask.trace(path, np.zeros((0, 6), np.float32), "test_occlusions", client=client)
    assert none.shape == (0,)


def test_a_scene_travels_once_per_client_and_loads_once_per_worker(client, bunny_scene, rays):
    rbdask.trace(bunny_scene, rays, "test_occlusions", client=client, chunk_rays=500)
    scatters = rbdask._client["scatters"]
    for query in QUERIES:
        rbdask.trace(bunny_scene, rays, query, client=client, chunk_rays=500)
    assert rbdask._client["scatters"] == scatters
    loads = client.run(rbdask._worker_loads)
    assert len(loads) == 2 and all(n == 1 for n in loads.values()), loads


def test_bad_calls_are_value_errors(client, bunny_scene, rays):
    bad = rays.copy()
    bad[2345, 4] = np.nan
    with pytest.raises(ValueError, match="ray 2345: ray direction is NaN"):
        rbdask.trace(bunny_scene, bad, "cast_rays", client=client, chunk_rays=1000)
    with pytest.raises(ValueError, match="query must be one of"):
        rbdask.trace(bunny_scene, rays, "compute_distance", client=client)
    with pytest.raises(ValueError, match="float32"):
        rbdask.trace(bunny_scene, rays.astype(np.float64), "cast_rays", client=client)
    with pytest.raises(ValueError, match="chunk_rays"):
        rbdask.trace(bunny_scene, rays, "cast_rays", client=client, chunk_rays=0)
    with pytest.raises(ValueError, match="scene must be"):
        rbdask.trace(3, rays, "cast_rays", client=client)
    with pytest.raises(ValueError, match="tfar must be a number"):
        rbdask.trace(bunny_scene, rays, "cast_rays", client=client, tfar=np.ones(len(rays)))


def test_the_default_local_cluster_and_the_example(tmp_path):
    """A script run as a user runs it: trace without a client, then the AO example."""
    script = tmp_path / "default.py"
    script.write_text(
        "import numpy as np, raybatch\n"
        "from raybatch.dask import trace\n"
        "if __name__ == '__main__':\n"
        f"    scene = raybatch.RaycastingScene(); scene.add_triangles({str(ROOT / 'data' / 'stanford-bunny.obj')!r})\n"
        "    rays = np.tile(np.float32([[0, 0.1, 1, 0, 0, -1]]), (1000, 1))\n"
        "    assert np.array_equal(trace(scene, rays, 'test_occlusions', chunk_rays=300), scene.test_occlusions(rays))\n"
    )
    subprocess.run([sys.executable, str(script)], check=True, capture_output=True, timeout=120)
    example = ROOT / "examples" / "python" / "bake_ao.py"
    out = tmp_path / "out"
    small = ["--rays-per-vertex", "4", "--size", "64", "--out", str(out)]
    subprocess.run([sys.executable, str(example), *small], check=True, capture_output=True, timeout=120)
    ao = np.load(out / "ao.npy")
    vertices, _ = raybatch.read_obj(ROOT / "data" / "stanford-bunny.obj")
    assert ao.shape == (len(vertices),) and ao.dtype == np.float32
    assert 0.5 < ao.mean() < 1 and ao.min() >= 0 and ao.max() <= 1
    from PIL import Image

    with Image.open(out / "ao.png") as image:
        assert image.size == (64, 64)
