"""Bakes per-vertex ambient occlusion of a mesh on a Dask cluster, and renders it.

    python examples/python/bake_ao.py                       # the bunny, a LocalCluster
    python examples/python/bake_ao.py --scheduler tcp://host:8786 --rays-per-vertex 256

For each vertex, rays in cosine-weighted directions about its normal go out from just above
the surface; the vertex's AO is the fraction that escape within ``--reach`` (a fraction of the
mesh's size). The rays are traced by ``raybatch.dask.trace``: the cooked scene is sent once to
every worker and the rays are answered in chunks. Writes ``ao.npy`` (one float32 per vertex,
1 = open) and ``ao.png`` (the mesh seen from the front, shaded by its AO) into ``--out``
(the current directory by default).
"""

import argparse
import pathlib
import time

import numpy as np

import raybatch
from raybatch.dask import trace

ROOT = pathlib.Path(__file__).resolve().parents[2]


def vertex_normals(vertices, triangles):
    """Area-weighted vertex normals (+z for a vertex no triangle with an area uses)."""
    a, b, c = (vertices[triangles[:, k]].astype(np.float64) for k in range(3))
    face = np.cross(b - a, c - a)
    normals = np.zeros((len(vertices), 3))
    for k in range(3):
        np.add.at(normals, triangles[:, k], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(length > 0, normals / np.where(length > 0, length, 1), [[0.0, 0, 1]])


def ao_rays(vertices, normals, per_vertex, offset, seed):
    """``per_vertex`` cosine-weighted rays about each normal, from ``offset`` above the vertex."""
    rng = np.random.default_rng(seed)
    n = np.repeat(normals, per_vertex, axis=0)
    # A tangent frame per ray.
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    u1, u2 = rng.random((2, len(n)))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    dirs = t * (r * np.cos(phi))[:, None] + b * (r * np.sin(phi))[:, None] + n * np.sqrt(1 - u1)[:, None]
    origins = np.repeat(vertices, per_vertex, axis=0) + n * offset
    return np.concatenate([origins, dirs], 1).astype(np.float32)


def render(scene, vertices, triangles, ao, size):
    """The mesh from the front, each pixel its hit's AO interpolated over the triangle."""
    centre = (vertices.min(0) + vertices.max(0)) / 2
    extent = np.ptp(vertices, 0).max()
    eye = centre + np.array([0, 0, 2.2 * extent])
    rays = raybatch.RaycastingScene.create_rays_pinhole(30.0, centre, eye, [0, 1, 0], size, size)
    hits = scene.cast_rays(rays, normals=False)
    hit = np.isfinite(hits["t_hit"])
    prim = np.where(hit, hits["primitive_ids"], 0)
    u, v = hits["primitive_uvs"][..., 0], hits["primitive_uvs"][..., 1]
    corners = ao[triangles[prim]]
    shade = (1 - u - v) * corners[..., 0] + u * corners[..., 1] + v * corners[..., 2]
    # AO squared for contrast; a dark background.
    image = np.where(hit, shade**2, 0.15)
    return (np.clip(image, 0, 1) * 255).astype(np.uint8)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mesh", default=ROOT / "data" / "stanford-bunny.obj", type=pathlib.Path)
    parser.add_argument("--out", default=pathlib.Path("."), type=pathlib.Path, help="output folder")
    parser.add_argument("--rays-per-vertex", default=64, type=int)
    parser.add_argument("--reach", default=0.5, type=float, help="ray length, times the mesh size")
    parser.add_argument("--size", default=512, type=int, help="picture width and height")
    parser.add_argument("--chunk-rays", default=1 << 19, type=int)
    parser.add_argument("--scheduler", help="a Dask scheduler address (default: a LocalCluster)")
    args = parser.parse_args()

    start = time.perf_counter()
    vertices, triangles = raybatch.read_obj(args.mesh)
    scene = raybatch.RaycastingScene()
    scene.add_triangles(vertices, triangles)
    extent = float(np.ptp(vertices, 0).max())
    normals = vertex_normals(vertices, triangles)
    rays = ao_rays(vertices, normals, args.rays_per_vertex, 1e-4 * extent, seed=1)

    client = None
    if args.scheduler:
        from distributed import Client

        client = Client(args.scheduler)
    occluded = trace(scene, rays, "test_occlusions", client=client, chunk_rays=args.chunk_rays, tfar=args.reach * extent)
    ao = 1 - occluded.reshape(len(vertices), args.rays_per_vertex).mean(1).astype(np.float32)

    args.out.mkdir(parents=True, exist_ok=True)
    np.save(args.out / "ao.npy", ao)
    from PIL import Image

    Image.fromarray(render(scene, vertices, triangles, ao, args.size)).save(args.out / "ao.png")
    seconds = time.perf_counter() - start
    print(f"{len(rays):,} rays, {len(vertices):,} vertices, mean AO {ao.mean():.3f}, {seconds:.1f} s")
    print(f"wrote {args.out / 'ao.npy'} and {args.out / 'ao.png'}")


if __name__ == "__main__":
    main()
