"""Batched exact ray queries against triangle meshes, under Open3D's ``RaycastingScene`` names.

``raybatch.RaycastingScene`` answers closest hits, occlusion, hit counts and every hit of large
batches of rays with the raybatch library: a watertight ray/triangle test (a ray through a
shared edge or vertex of a closed mesh hits it), the lowest triangle id on equal ``t``, the
same answers for every structure kind and thread count. Arrays are NumPy arrays; the GIL is
released while meshes are built or loaded and while rays are answered.

>>> import numpy as np, raybatch
>>> scene = raybatch.RaycastingScene()
>>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
>>> scene.add_triangles(vertices, np.array([[0, 1, 2]], np.uint32))
0
>>> rays = np.array([[0.2, 0.2, 1, 0, 0, -1]], np.float32)
>>> float(scene.cast_rays(rays)["t_hit"][0])
1.0

``raybatch.dask.trace`` spreads a batch over a Dask cluster. python/README.md lists the
differences from Open3D.
"""

import numbers
import os

import numpy as np

from . import _raybatch
from ._raybatch import COOKED_KINDS, FORMAT_VERSION, INVALID_ID, KINDS, read_obj

__all__ = [
    "RaycastingScene",
    "read_obj",
    "KINDS",
    "COOKED_KINDS",
    "INVALID_ID",
    "FORMAT_VERSION",
]


def _count(value, name):
    """A thread count: an int >= 0 (0 is every core), never a bool."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an int >= 0, not {value!r}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0, not {value}")
    return int(value)


def _rays(rays):
    """``rays`` as an ``(N, 6)`` C-contiguous aligned float32 array (the same memory when it
    already is one) and the leading shape of the answers."""
    array = np.asarray(rays)
    if array.dtype != np.float32:
        raise ValueError(f"rays must be float32, not {array.dtype}")
    if array.ndim < 1 or array.shape[-1] != 6:
        raise ValueError(f"rays must have shape (..., 6), not {array.shape}")
    leading = array.shape[:-1]
    # A copy only for strided or unaligned arrays (Dask hands workers unaligned ones).
    array = np.require(array, np.float32, ["C", "A"])
    return array.reshape(-1, 6), leading


def _limit(value, name, leading):
    """``tnear`` or ``tfar``: a number for all rays, or one float per ray (an array of the
    rays' leading shape)."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    array = np.asarray(value)
    if array.dtype.kind != "f":
        raise ValueError(f"{name} must be a number or a float array, not {array.dtype}")
    if array.shape != leading:
        raise ValueError(f"{name} must be a number or of shape {leading}, not {array.shape}")
    return np.require(array, np.float32, ["C", "A"]).reshape(-1)


def _indices(triangles):
    """``(F, 3)`` integer triangle indices as uint32 (the same memory when they already are)."""
    array = np.asarray(triangles)
    if array.dtype.kind not in "iu":
        raise ValueError(f"triangle indices must be integers, not {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"triangle indices must have shape (F, 3), not {array.shape}")
    if array.size:
        low, high = int(array.min()), int(array.max())
        if low < 0:
            raise ValueError(f"triangle index {low} is negative")
        if high > 0xFFFF_FFFF:
            raise ValueError(f"triangle index {high} does not fit 32 bits")
    return np.require(array, np.uint32, ["C", "A"])


def _vertices(vertices):
    array = np.asarray(vertices)
    if array.dtype != np.float32:
        raise ValueError(f"vertex positions must be float32, not {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"vertex positions must have shape (V, 3), not {array.shape}")
    return np.require(array, np.float32, ["C", "A"])


def _vector(value, name, size):
    """A float64 vector of ``size`` numbers (camera parameters)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {size} numbers, not {value!r}") from None
    if array.size != size:
        raise ValueError(f"{name} must be {size} numbers, not {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite")
    return array.reshape(-1)


def _pixels(width_px, height_px):
    for name, value in (("width_px", width_px), ("height_px", height_px)):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value <= 0:
            raise ValueError(f"{name} must be an int > 0, not {value!r}")
    return int(width_px), int(height_px)


def _pinhole(intrinsic, extrinsic, width_px, height_px):
    """Open3D's camera rays: from the camera centre ``-R^T t`` through each pixel's centre,
    directions ``(R^T K^-1)`` (in float32) times ``(x + 0.5, y + 0.5, 1)``."""
    k = _vector(intrinsic, "intrinsic_matrix", 9).reshape(3, 3)
    e = _vector(extrinsic, "extrinsic_matrix", 16).reshape(4, 4)
    width, height = _pixels(width_px, height_px)
    try:
        k_inv = np.linalg.inv(k)
    except np.linalg.LinAlgError:
        raise ValueError("intrinsic_matrix is singular") from None
    r, t = e[:3, :3], e[:3, 3]
    centre = -r.T @ t
    m = (r.T @ k_inv).astype(np.float32)
    x = np.arange(width, dtype=np.float32) + np.float32(0.5)
    y = (np.arange(height, dtype=np.float32) + np.float32(0.5))[:, None]
    rays = np.empty((height, width, 6), np.float32)
    rays[..., :3] = centre.astype(np.float32)
    for i in range(3):
        rays[..., 3 + i] = m[i, 0] * x + m[i, 1] * y + m[i, 2]
    return rays


def _look_at(fov_deg, center, eye, up, width_px, height_px):
    """Open3D's look-at camera as intrinsic and extrinsic matrices."""
    fov = float(_vector(fov_deg, "fov_deg", 1)[0])
    if not 0.0 < fov < 180.0:
        raise ValueError(f"fov_deg must be in (0, 180), not {fov}")
    center, eye, up = (_vector(v, n, 3) for v, n in ((center, "center"), (eye, "eye"), (up, "up")))
    width, height = _pixels(width_px, height_px)
    focal = 0.5 * width / np.tan(0.5 * np.radians(fov))
    intrinsic = np.array([[focal, 0, 0.5 * width], [0, focal, 0.5 * height], [0, 0, 1]])
    w = eye - center
    u = np.cross(up, w)
    if not np.linalg.norm(w) or not np.linalg.norm(u):
        raise ValueError("eye must differ from center, and up must not be along the view")
    w /= np.linalg.norm(w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    v /= np.linalg.norm(v)
    r = np.stack([u, -v, -w])
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = r
    extrinsic[:3, 3] = -r @ eye
    return _pinhole(intrinsic, extrinsic, width, height)


class RaycastingScene:
    """Triangle meshes (geometries) and the ray queries over them, as Open3D's
    ``open3d.t.geometry.RaycastingScene``.

    ``nthreads`` is the threads mesh builds use (0: every core). ``kind`` names the structure
    every geometry is built with (one of ``raybatch.KINDS``); ``None`` lets the library pick
    per mesh. Every kind gives the same answers; they differ in speed and memory, and only
    ``raybatch.COOKED_KINDS`` can be saved.
    """

    #: The geometry and primitive id of a miss.
    INVALID_ID = INVALID_ID

    def __init__(self, nthreads=0, *, kind=None):
        self._nthreads = _count(nthreads, "nthreads")
        if kind is not None and not isinstance(kind, str):
            raise ValueError(f"kind must be a name from raybatch.KINDS, not {kind!r}")
        self._scene = _raybatch.Scene(kind)

    @classmethod
    def _wrap(cls, scene, nthreads):
        self = cls.__new__(cls)
        self._nthreads = _count(nthreads, "nthreads")
        self._scene = scene
        return self

    def add_triangles(self, vertex_positions, triangle_indices=None):
        """Adds a mesh and returns its geometry id: ``(V, 3)`` float32 vertex positions and
        ``(F, 3)`` integer triangle indices, a mesh object with ``vertices`` and ``triangles``
        (Open3D's legacy ``TriangleMesh``, trimesh's ``Trimesh``), or the path of an OBJ file."""
        if triangle_indices is None:
            if isinstance(vertex_positions, (str, os.PathLike)):
                return self._scene.add_obj(os.fspath(vertex_positions), self._nthreads)
            mesh = vertex_positions
            if not (hasattr(mesh, "vertices") and hasattr(mesh, "triangles")):
                raise ValueError("add_triangles takes arrays, a mesh or an OBJ path")
            vertices = np.asarray(mesh.vertices, dtype=np.float32)
            return self.add_triangles(vertices, np.asarray(mesh.triangles))
        vertices, triangles = _vertices(vertex_positions), _indices(triangle_indices)
        return self._scene.add_arrays(vertices, triangles, self._nthreads)

    def _query(self, rays, nthreads, tnear, tfar):
        rays, leading = _rays(rays)
        limits = (_limit(tnear, "tnear", leading), _limit(tfar, "tfar", leading))
        return rays, leading, limits, _count(nthreads, "nthreads")

    def cast_rays(self, rays, nthreads=0, *, tnear=0.0, tfar=np.inf, normals=True):
        """The closest hit of each ray of ``rays`` (``(..., 6)`` float32: origin, direction;
        ``t`` in units of the direction) in ``[tnear, tfar]``: a dict of ``t_hit``,
        ``geometry_ids``, ``primitive_ids``, ``primitive_uvs`` and ``primitive_normals`` (unit
        triangle normals, skipped with ``normals=False``). A miss has ``t_hit = inf`` and ids
        ``INVALID_ID``."""
        rays, leading, (tnear, tfar), nthreads = self._query(rays, nthreads, tnear, tfar)
        t, geometry, primitive, uv, normal = self._scene.cast_rays(
            rays, tnear, tfar, nthreads, bool(normals)
        )
        answer = {
            "t_hit": t.reshape(leading),
            "geometry_ids": geometry.reshape(leading),
            "primitive_ids": primitive.reshape(leading),
            "primitive_uvs": uv.reshape(leading + (2,)),
        }
        if normals:
            answer["primitive_normals"] = normal.reshape(leading + (3,))
        return answer

    def test_occlusions(self, rays, tnear=0.0, tfar=np.inf, nthreads=0):
        """Whether each ray hits anything in ``[tnear, tfar]`` (numbers, or arrays of the rays'
        leading shape): a bool array."""
        rays, leading, (tnear, tfar), nthreads = self._query(rays, nthreads, tnear, tfar)
        return self._scene.test_occlusions(rays, tnear, tfar, nthreads).reshape(leading)

    def count_intersections(self, rays, nthreads=0, *, tnear=0.0, tfar=np.inf):
        """The number of triangles each ray hits in ``[tnear, tfar]``: an int32 array."""
        rays, leading, (tnear, tfar), nthreads = self._query(rays, nthreads, tnear, tfar)
        return self._scene.count_intersections(rays, tnear, tfar, nthreads).reshape(leading)

    def list_intersections(self, rays, nthreads=0, *, tnear=0.0, tfar=np.inf):
        """Every hit of every ray, ragged: ray ``i``'s hits are ``ray_splits[i]`` to
        ``ray_splits[i + 1]`` of the flat arrays ``ray_ids`` (into the flattened rays),
        ``geometry_ids``, ``primitive_ids``, ``primitive_uvs`` and ``t_hit``, by ``t`` then
        geometry and primitive id."""
        rays, _, (tnear, tfar), nthreads = self._query(rays, nthreads, tnear, tfar)
        splits, ray, geometry, primitive, uv, t = self._scene.list_intersections(
            rays, tnear, tfar, nthreads
        )
        return {
            "ray_splits": splits,
            "ray_ids": ray,
            "geometry_ids": geometry,
            "primitive_ids": primitive,
            "primitive_uvs": uv.reshape(-1, 2),
            "t_hit": t,
        }

    def geometry_count(self):
        """The number of geometries."""
        return self._scene.geometry_count()

    def triangle_count(self):
        """Triangles over all geometries."""
        return self._scene.triangle_count()

    def kinds(self):
        """Each geometry's structure kind (a name from ``raybatch.KINDS``)."""
        return self._scene.kinds()

    def to_bytes(self):
        """The scene as the bytes of a cooked file (meshes and trees; a ``ValueError`` for
        kinds outside ``raybatch.COOKED_KINDS``)."""
        return self._scene.to_bytes()

    def save(self, path):
        """Writes the scene to a cooked file (``to_bytes``)."""
        self._scene.save(os.fspath(path))

    @classmethod
    def from_bytes(cls, data, nthreads=0, *, kind=None):
        """The scene of a cooked file's bytes, answering bit for bit as the one saved; a
        damaged, truncated, foreign or newer file is a ``ValueError``. ``nthreads`` and
        ``kind`` apply to geometries added later."""
        return cls._wrap(_raybatch.Scene.from_bytes(bytes(data), kind), nthreads)

    @classmethod
    def load(cls, path, nthreads=0, *, kind=None):
        """The scene of a cooked file (``from_bytes``); a missing file is an ``OSError``."""
        return cls._wrap(_raybatch.Scene.load(os.fspath(path), kind), nthreads)

    @staticmethod
    def create_rays_pinhole(*args, **kwargs):
        """Camera rays, ``(height_px, width_px, 6)`` float32, in Open3D's two forms:
        ``create_rays_pinhole(intrinsic_matrix, extrinsic_matrix, width_px, height_px)`` and
        ``create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px)``."""
        matrices = ("intrinsic_matrix", "extrinsic_matrix", "width_px", "height_px")
        look_at = ("fov_deg", "center", "eye", "up", "width_px", "height_px")
        for names, make in ((matrices, _pinhole), (look_at, _look_at)):
            if len(args) <= len(names) and len(args) + len(kwargs) == len(names):
                values = dict(zip(names, args))
                if set(kwargs) == set(names[len(args):]):
                    values.update(kwargs)
                    return make(*(values[n] for n in names))
        raise ValueError(
            "create_rays_pinhole takes (intrinsic_matrix, extrinsic_matrix, width_px, "
            "height_px) or (fov_deg, center, eye, up, width_px, height_px)"
        )

    def __repr__(self):
        return (
            f"RaycastingScene({self.geometry_count()} geometries, "
            f"{self.triangle_count()} triangles)"
        )
