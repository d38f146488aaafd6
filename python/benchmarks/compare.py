"""raybatch against the ray casters Python users have today, on the same meshes and rays.

    python python/benchmarks/compare.py [--rays N] [--runs K] [--meshes bunny,terrain]

Engines: raybatch's ``RaycastingScene``, Open3D's ``open3d.t.geometry.RaycastingScene`` (on
Embree) and trimesh's ``RayMeshIntersector`` over embreex (Embree too; one core, as trimesh
calls it). Each engine that imports takes part; the others are named and skipped.

For each mesh it prints, per engine and thread count, the best rays per second of ``--runs``
rounds taken in turns (every engine once per round, so drift on the machine hits all alike),
closest hit of incoherent rays (origins uniform in the mesh's box, directions uniform). Then
agreement with raybatch on the same rays: hit or miss, triangle, and ``t`` beyond a relative
1e-5. Last, leaks: on a closed, jittered sphere, rays from inside aimed exactly at its vertices
and at the midpoints of its edges, where a ray that hits nothing has passed through the mesh.
"""

import argparse
import os
import sys
import time

# NumPy's BLAS threads would spin beside the engines after the rays are made.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import raybatch  # noqa: E402

MISS = np.uint32(0xFFFFFFFF)


def bunny():
    here = os.path.dirname(os.path.abspath(__file__))
    vertices, triangles = raybatch.read_obj(
        os.path.join(here, "..", "..", "data", "stanford-bunny.obj")
    )
    return np.asarray(vertices, np.float32), np.asarray(triangles, np.uint32)


def terrain(side=708, seed=1):
    """A heightfield of ``2 * (side - 1)^2`` triangles (about 1M for the default side): rolling
    hills with a little noise, on a 100 x 100 square."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 100, side), np.linspace(0, 100, side))
    z = 4 * np.sin(x / 9) * np.cos(y / 13) + 1.5 * np.sin(x / 3 + y / 5)
    z += rng.uniform(-0.05, 0.05, z.shape)
    vertices = np.stack([x, y, z], -1).reshape(-1, 3).astype(np.float32)
    i = np.arange(side - 1)
    corner = (i[:, None] * side + i[None, :]).ravel()
    quads = np.stack([corner, corner + 1, corner + side, corner + side + 1], -1)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [1, 3, 2]]])
    return vertices, triangles.astype(np.uint32)


def jittered_sphere(subdivisions=5, jitter=0.01, seed=2):
    """A closed icosphere whose vertices are moved along their radius by up to ``jitter``."""
    t = (1 + 5**0.5) / 2
    vertices = np.array(
        [
            [-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
            [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
            [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1],
        ],
        np.float64,
    )
    faces = np.array(
        [
            [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
            [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
            [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
            [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
        ]
    )
    for _ in range(subdivisions):
        vertices, faces = _subdivide(vertices, faces)
    vertices /= np.linalg.norm(vertices, axis=1, keepdims=True)
    rng = np.random.default_rng(seed)
    vertices *= 1 + rng.uniform(-jitter, jitter, (len(vertices), 1))
    return vertices.astype(np.float32), faces.astype(np.uint32)


def _subdivide(vertices, faces):
    """Each triangle into four, the new vertices shared between neighbours."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mids = (vertices[unique[:, 0]] + vertices[unique[:, 1]]) / 2
    m = inverse.reshape(3, -1) + len(vertices)
    a, b, c = faces.T
    new = np.stack(
        [
            np.stack([a, m[0], m[2]], 1),
            np.stack([b, m[1], m[0]], 1),
            np.stack([c, m[2], m[1]], 1),
            np.stack([m[0], m[1], m[2]], 1),
        ]
    ).reshape(-1, 3)
    return np.concatenate([vertices, mids]), new


def incoherent_rays(vertices, count, seed=3):
    rng = np.random.default_rng(seed)
    lo, hi = vertices.min(0), vertices.max(0)
    origins = rng.uniform(lo, hi, (count, 3))
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.concatenate([origins, directions], 1).astype(np.float32)


def leak_rays(vertices, faces, count, seed=4):
    """Rays from points near the sphere's centre through its vertices and edge midpoints (as
    float32 points), half each."""
    rng = np.random.default_rng(seed)
    edges = np.unique(
        np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1),
        axis=0,
    )
    half = count // 2
    targets = np.concatenate(
        [
            vertices[rng.integers(0, len(vertices), half)],
            (vertices[edges[rng.integers(0, len(edges), count - half)]].mean(1)).astype(
                np.float32
            ),
        ]
    ).astype(np.float32)
    origins = rng.uniform(-0.3, 0.3, (count, 3)).astype(np.float32)
    return np.concatenate([origins, targets - origins], 1).astype(np.float32)


class Raybatch:
    name = "raybatch"
    cores = "each"

    def __init__(self, vertices, triangles):
        self.scene = raybatch.RaycastingScene()
        self.scene.add_triangles(vertices, triangles)

    def cast(self, rays, threads):
        hits = self.scene.cast_rays(rays, nthreads=threads)
        return hits["t_hit"], hits["primitive_ids"]


class Open3D:
    name = "Open3D"
    cores = "each"

    def __init__(self, vertices, triangles):
        import open3d as o3d

        self.o3d = o3d
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))

    def cast(self, rays, threads):
        hits = self.scene.cast_rays(self.o3d.core.Tensor(rays), nthreads=threads)
        return hits["t_hit"].numpy(), hits["primitive_ids"].numpy()


class Trimesh:
    name = "trimesh + embreex"
    cores = "one"

    def __init__(self, vertices, triangles):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        mesh = trimesh.Trimesh(vertices, triangles, process=False)
        self.intersector = RayMeshIntersector(mesh)

    def cast(self, rays, threads):
        origins, directions = rays[:, :3], rays[:, 3:]
        tri, ray, points = self.intersector.intersects_id(
            origins, directions, multiple_hits=False, return_locations=True
        )
        t = np.full(len(rays), np.inf, np.float32)
        ids = np.full(len(rays), MISS, np.uint32)
        lengths = np.linalg.norm(directions[ray], axis=1)
        t[ray] = np.linalg.norm(points - origins[ray], axis=1) / lengths
        ids[ray] = tri
        return t, ids


ENGINES = [Raybatch, Open3D, Trimesh]


def available(vertices, triangles):
    """The engines that import and build, each with its build time in ms (Open3D and trimesh
    build at their first query, so the time includes one ray)."""
    made = []
    one_ray = np.array([[0, 0, 0, 0, 0, 1]], np.float32)
    for engine in ENGINES:
        try:
            start = time.perf_counter()
            built = engine(vertices, triangles)
            built.cast(one_ray, 0)
            made.append((built, 1e3 * (time.perf_counter() - start)))
        except ImportError as error:
            print(f"  {engine.name}: skipped ({error})", file=sys.stderr)
    return made


def thread_counts(engine):
    cores = os.cpu_count() or 1
    return [1, 0] if engine.cores == "each" and cores > 1 else [1]


def race(engines, rays, runs):
    """Best seconds per (engine, threads) over ``runs`` rounds in turns, and each one's
    answers."""
    best, answers = {}, {}
    for _ in range(runs):
        for engine, _ in engines:
            for threads in thread_counts(engine):
                start = time.perf_counter()
                answers[engine.name] = engine.cast(rays, threads)
                seconds = time.perf_counter() - start
                key = (engine.name, threads)
                best[key] = min(best.get(key, np.inf), seconds)
    return best, answers


def agreement(reference, other):
    """Rays that disagree on hit or miss, on the triangle, and on t beyond a relative 1e-5."""
    (t0, id0), (t1, id1) = reference, other
    hit0, hit1 = id0 != MISS, id1 != MISS
    both = hit0 & hit1
    relative = np.abs(t0[both] - t1[both]) / np.maximum(np.abs(t0[both]), 1e-30)
    return int((hit0 != hit1).sum()), int((id0[both] != id1[both]).sum()), int(
        (relative > 1e-5).sum()
    )


def speed_table(name, triangles, rays, engines, best):
    cores = os.cpu_count() or 1
    print(f"\n### {name}: {triangles:,} triangles, {len(rays):,} incoherent rays\n")
    print("| engine | build (ms) | one core (Mrays/s) | all cores (Mrays/s) |")
    print("| --- | ---: | ---: | ---: |")
    for engine, build_ms in engines:
        one = len(rays) / best[(engine.name, 1)] / 1e6
        every = best.get((engine.name, 0))
        every = f"{len(rays) / every / 1e6:.2f}" if every is not None and cores > 1 else "-"
        print(f"| {engine.name} | {build_ms:.1f} | {one:.2f} | {every} |")
    for other, _ in engines[1:]:
        for threads in thread_counts(other):
            mine = best[("raybatch", threads)]
            label = "one core" if threads == 1 else "all cores"
            print(f"\nraybatch over {other.name}, {label}: {best[(other.name, threads)] / mine:.2f}x")


def agreement_table(rays, engines, answers):
    print("\n| engine against raybatch | hit or miss differs | triangle differs | t differs |")
    print("| --- | ---: | ---: | ---: |")
    for engine, _ in engines[1:]:
        miss, tri, t = agreement(answers["raybatch"], answers[engine.name])
        print(f"| {engine.name} | {miss} | {tri} | {t} |")


def leaks(count):
    vertices, faces = jittered_sphere()
    rays = leak_rays(vertices, faces, count)
    engines = available(vertices, faces)
    print(
        f"\n### Leaks: closed jittered sphere, {len(faces):,} triangles, {count:,} rays from "
        "inside through its vertices and edge midpoints\n"
    )
    print("| engine | rays that hit nothing |")
    print("| --- | ---: |")
    for engine, _ in engines:
        _, ids = engine.cast(rays, 0 if engine.cores == "each" else 1)
        print(f"| {engine.name} | {int((ids == MISS).sum())} |")


MESHES = {"bunny": bunny, "terrain": terrain}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rays", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--meshes", default="bunny,terrain")
    parser.add_argument("--leak-rays", type=int, default=200_000)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores; {sys.version.split()[0]}")
    for name in args.meshes.split(","):
        vertices, triangles = MESHES[name]()
        rays = incoherent_rays(vertices, args.rays)
        engines = available(vertices, triangles)
        best, answers = race(engines, rays, args.runs)
        speed_table(name, len(triangles), rays, engines, best)
        agreement_table(rays, engines, answers)
    leaks(args.leak_rays)


if __name__ == "__main__":
    main()
