"""Ray batches spread over a Dask cluster: ``trace(scene, rays, query)``.

The scene travels as a cooked file's bytes, once per client (``client.scatter`` with
``broadcast=True``); each worker process loads it once and keeps the last few scenes it
loaded, keyed by the bytes' SHA-256. The rays (a NumPy or a Dask array of shape ``(..., 6)``)
are cut into chunks of ``chunk_rays``, each chunk is answered on a worker with the same
``RaycastingScene`` query, and the answers are gathered in order: the result is what the query
gives in one process, bit for bit.

>>> from raybatch.dask import trace
>>> hits = trace("level.rbt", rays, "cast_rays")                      # a LocalCluster
>>> hits = trace(scene, rays, "test_occlusions", client=Client("tcp://scheduler:8786"))

Without ``client``, ``trace`` starts a ``LocalCluster`` on this machine for the call (one
worker process per core) and closes it after; pass a ``Client`` to reuse a cluster, local or
remote, the same way.
"""

import collections
import hashlib
import os
import re
import threading

import numpy as np

from . import RaycastingScene

__all__ = ["trace", "QUERIES"]

#: The queries ``trace`` runs: ``RaycastingScene`` methods.
QUERIES = ("cast_rays", "test_occlusions", "count_intersections", "list_intersections")

#: Scenes a worker keeps loaded.
WORKER_SCENES = 4
#: Scattered scenes a client process remembers.
CLIENT_SCENES = 8

_worker = {"scenes": collections.OrderedDict(), "loads": 0, "lock": threading.Lock()}
_client = {"scattered": collections.OrderedDict(), "scatters": 0, "lock": threading.Lock()}


def _scene_bytes(scene):
    """The cooked bytes of a path, bytes or a ``RaycastingScene``."""
    if isinstance(scene, RaycastingScene):
        return scene.to_bytes()
    if isinstance(scene, (bytes, bytearray, memoryview)):
        return bytes(scene)
    if isinstance(scene, (str, os.PathLike)):
        with open(scene, "rb") as file:
            return file.read()
    raise ValueError(f"scene must be a path, bytes or a RaycastingScene, not {type(scene)}")


def _worker_scene(key, data):
    """This worker process's scene for ``key`` (loaded from ``data`` on first use)."""
    with _worker["lock"]:
        scenes = _worker["scenes"]
        if key in scenes:
            scenes.move_to_end(key)
            return scenes[key]
        scene = RaycastingScene.from_bytes(data)
        _worker["loads"] += 1
        scenes[key] = scene
        while len(scenes) > WORKER_SCENES:
            scenes.popitem(last=False)
        return scene


def _worker_loads():
    """Scenes this worker process has loaded (for tests)."""
    return _worker["loads"]


def _answer(data, key, query, start, rays, options):
    """One chunk's answer on a worker. A bad ray's index is renumbered over all rays."""
    scene = _worker_scene(key, data)
    try:
        return getattr(scene, query)(rays, **options)
    except ValueError as e:
        message = re.sub(r"^ray (\d+):", lambda m: f"ray {start + int(m[1])}:", str(e))
        raise ValueError(message) from None


def _scattered(client, key, data, cache):
    """The future of the scene's bytes on every worker, sent once per client."""
    if not cache:
        _client["scatters"] += 1
        return client.scatter(data, broadcast=True, hash=False)
    with _client["lock"]:
        scattered = _client["scattered"]
        entry = (client.id, key)
        if entry in scattered and scattered[entry].status in ("pending", "finished"):
            scattered.move_to_end(entry)
            return scattered[entry]
        _client["scatters"] += 1
        future = client.scatter(data, broadcast=True, hash=False)
        scattered[entry] = future
        while len(scattered) > CLIENT_SCENES:
            scattered.popitem(last=False)
        return future


def _chunks(rays, chunk_rays):
    """The rays as ``(N, 6)`` chunks (NumPy arrays or Dask delayed objects) with their first
    ray's index, and the leading shape."""
    if hasattr(rays, "dask") and hasattr(rays, "rechunk"):
        if rays.ndim < 1 or rays.shape[-1] != 6:
            raise ValueError(f"rays must have shape (..., 6), not {rays.shape}")
        if any(np.isnan(n) for n in rays.shape):
            raise ValueError("rays of unknown shape: compute their chunk sizes first")
        flat = rays.reshape(-1, 6).rechunk((chunk_rays, 6))
        starts = np.cumsum((0,) + flat.chunks[0][:-1])
        return list(zip(starts.tolist(), flat.to_delayed().ravel())), rays.shape[:-1], flat.dtype
    array = np.asarray(rays)
    if array.ndim < 1 or array.shape[-1] != 6:
        raise ValueError(f"rays must have shape (..., 6), not {array.shape}")
    flat = array.reshape(-1, 6)
    starts = range(0, len(flat), chunk_rays)
    return [(s, flat[s : s + chunk_rays]) for s in starts], array.shape[:-1], flat.dtype


def _merge(query, parts, leading):
    """The chunks' answers as one answer."""
    if query in ("test_occlusions", "count_intersections"):
        return np.concatenate(parts).reshape(leading)
    if query == "cast_rays":
        keys = parts[0].keys()
        merged = {k: np.concatenate([p[k] for p in parts]) for k in keys}
        return {k: v.reshape(leading + v.shape[1:]) for k, v in merged.items()}
    splits, offset, first = [np.zeros(1, np.uint32)], 0, 0
    for part in parts:
        splits.append(part["ray_splits"][1:] + np.uint32(offset))
        offset += len(part["t_hit"])
    flat = {
        k: np.concatenate([p[k] for p in parts])
        for k in ("geometry_ids", "primitive_ids", "primitive_uvs", "t_hit")
    }
    ray_ids = []
    for part in parts:
        ray_ids.append(part["ray_ids"] + np.uint32(first))
        first += len(part["ray_splits"]) - 1
    return {"ray_splits": np.concatenate(splits), "ray_ids": np.concatenate(ray_ids), **flat}


def trace(scene, rays, query, client=None, chunk_rays=1 << 20, **options):
    """Answers ``query`` (one of ``QUERIES``) for ``rays`` on a Dask cluster.

    ``scene``: a cooked file's path, its bytes or a ``RaycastingScene`` (of a kind that cooks).
    ``rays``: a NumPy or Dask array of shape ``(..., 6)``, float32. ``client``: a
    ``distributed.Client``; without one, a ``LocalCluster`` runs for the call. ``chunk_rays``:
    rays per task. ``options``: the query's keyword arguments (``nthreads`` per worker,
    ``tnear`` and ``tfar`` as numbers, ``normals``). Returns what the query returns in one
    process, the same answers; a bad ray is a ``ValueError`` naming its index among all rays.
    """
    if query not in QUERIES:
        raise ValueError(f"query must be one of {QUERIES}, not {query!r}")
    if isinstance(chunk_rays, bool) or not isinstance(chunk_rays, int) or chunk_rays <= 0:
        raise ValueError(f"chunk_rays must be an int > 0, not {chunk_rays!r}")
    for name in ("tnear", "tfar"):
        if name in options and np.ndim(options[name]) != 0:
            raise ValueError(f"{name} must be a number in trace (one range for every ray)")
    data = _scene_bytes(scene)
    chunks, leading, dtype = _chunks(rays, chunk_rays)
    if dtype != np.float32:
        raise ValueError(f"rays must be float32, not {dtype}")
    if client is None:
        from distributed import Client, LocalCluster

        with LocalCluster(processes=True) as cluster, Client(cluster) as own:
            return _trace(own, data, chunks, leading, query, options, cache=False)
    return _trace(client, data, chunks, leading, query, options, cache=True)


def _trace(client, data, chunks, leading, query, options, cache):
    key = hashlib.sha256(data).hexdigest()
    if not chunks:
        no_rays = np.zeros((0, 6), np.float32)
        answer = getattr(RaycastingScene.from_bytes(data), query)(no_rays, **options)
        return _merge(query, [answer], leading)
    scene = _scattered(client, key, data, cache)
    delayed = [c for _, c in chunks if not isinstance(c, np.ndarray)]
    computed = iter(client.compute(delayed)) if delayed else iter(())
    arrays = [c if isinstance(c, np.ndarray) else next(computed) for _, c in chunks]
    if all(isinstance(a, np.ndarray) for a in arrays):
        arrays = client.scatter(arrays, hash=False)
    futures = [
        client.submit(_answer, scene, key, query, start, array, options, pure=False)
        for (start, _), array in zip(chunks, arrays)
    ]
    return _merge(query, client.gather(futures), leading)
