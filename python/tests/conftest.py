"""Shared meshes, rays and the command-line tool the answers are compared with."""

import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import raybatch

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUNNY = ROOT / "data" / "stanford-bunny.obj"


def incoherent(vertices, count, seed):
    """Rays from points in the mesh's box (grown by 5%) in directions uniform in a cube."""
    rng = np.random.default_rng(seed)
    low, high = vertices.min(0), vertices.max(0)
    margin = (high - low) * 0.05
    origins = rng.uniform(low - margin, high + margin, (count, 3))
    dirs = rng.uniform(-1, 1, (count, 3))
    return np.concatenate([origins, dirs], 1).astype(np.float32)


def towards(vertices, count, seed):
    """Rays from outside the mesh aimed at its vertices (grazing edges and corners)."""
    rng = np.random.default_rng(seed)
    centre = (vertices.min(0) + vertices.max(0)) / 2
    targets = vertices[rng.integers(0, len(vertices), count)]
    origins = centre + rng.normal(size=(count, 3)) * np.ptp(vertices, 0).max()
    return np.concatenate([origins, targets - origins], 1).astype(np.float32)


@pytest.fixture(scope="package")
def bunny():
    return raybatch.read_obj(BUNNY)


@pytest.fixture(scope="package")
def bunny_scene(bunny):
    scene = raybatch.RaycastingScene()
    scene.add_triangles(*bunny)
    return scene


@pytest.fixture(scope="package")
def rays(bunny):
    return np.concatenate([incoherent(bunny[0], 3000, 1), towards(bunny[0], 1000, 2)])


@pytest.fixture(scope="package")
def cli():
    """The `raybatch` command (RAYBATCH_CLI, or the workspace's release build)."""
    path = os.environ.get("RAYBATCH_CLI") or ROOT / "target" / "release" / "raybatch"
    if not pathlib.Path(path).exists():
        path = shutil.which("raybatch")
    if not path:
        pytest.fail("no raybatch command: cargo build --release -p raybatch-tools")
    return str(path)


def cli_query(cli, mesh, rays, kind, tmp_path, *flags, tnear=0.0, tfar=np.inf):
    """`raybatch query`'s answers to `rays`: closest as (t, triangle, u, v), any as bools."""
    records = np.zeros((len(rays), 8), np.float32)
    records[:, :6], records[:, 6], records[:, 7] = rays, tnear, tfar
    ray_file, out = tmp_path / "rays.bin", tmp_path / "hits.bin"
    records.astype("<f4").tofile(ray_file)
    command = [cli, "query", "--mesh", str(mesh), "--rays", str(ray_file), "--kind", kind]
    subprocess.run(command + ["--out", str(out), *flags], check=True, capture_output=True)
    data = out.read_bytes()
    if kind == "any":
        return np.frombuffer(data, np.uint8).astype(bool)
    hits = np.frombuffer(data, np.dtype([("t", "<f4"), ("id", "<u4"), ("u", "<f4"), ("v", "<f4")]))
    return hits
