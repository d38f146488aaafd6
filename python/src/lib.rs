//! The `raybatch._raybatch` extension module: the library's structures and scenes behind one
//! Python class, `Scene`, which `raybatch.RaycastingScene` (python/raybatch) wraps under
//! Open3D's names. Arrays arrive checked and C-contiguous from that layer; this module reads
//! them in place, releases the GIL for every build, load and query, and turns the library's
//! errors into `ValueError` (bad data) and `OSError` (files).

mod rays;
mod target;
mod threads;

use std::path::PathBuf;

use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use raybatch::glam::Vec3;
use raybatch::{AccelKind, BuildOptions, CookError, Mesh, MeshError};

use crate::rays::{Limit, Rays};
use crate::target::{Geometries, INVALID_ID};

/// A `ValueError` with the library's message.
fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A mesh error: `OSError` if the file could not be read, else `ValueError`.
fn mesh_error(e: MeshError) -> PyErr {
    match e {
        MeshError::Io { .. } => PyOSError::new_err(e.to_string()),
        e => value_error(e),
    }
}

/// A cooked file's error: `OSError` if the file could not be read or written, else
/// `ValueError`.
fn cook_error(e: CookError) -> PyErr {
    match e {
        CookError::Io(_) => PyOSError::new_err(e.to_string()),
        e => value_error(e),
    }
}

/// The C-contiguous data of `array` (the Python layer passes no other).
fn data<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    array: &'a numpy::PyReadonlyArray<'_, T, D>,
) -> PyResult<&'a [T]> {
    if !array.is_c_contiguous() {
        return Err(value_error("array is not C-contiguous"));
    }
    array.as_slice().map_err(value_error)
}

/// `tnear` or `tfar`: one number for every ray, or a float32 array of one per ray.
#[derive(FromPyObject)]
enum LimitArg<'py> {
    PerRay(PyReadonlyArray1<'py, f32>),
    All(f32),
}

impl LimitArg<'_> {
    fn limit(&self) -> PyResult<Limit<'_>> {
        Ok(match self {
            LimitArg::PerRay(values) => Limit::PerRay(data(values)?),
            LimitArg::All(t) => Limit::All(*t),
        })
    }
}

/// The rays of an `(N, 6)` array over `[tnear, tfar]`.
fn rays<'a>(
    rays: &'a PyReadonlyArray2<'_, f32>,
    tnear: &'a LimitArg<'_>,
    tfar: &'a LimitArg<'_>,
) -> PyResult<Rays<'a>> {
    Rays::new(data(rays)?, tnear.limit()?, tfar.limit()?).map_err(value_error)
}

/// Geometries under one structure kind (or the library's pick per mesh), queried in batches.
#[pyclass(module = "raybatch._raybatch")]
struct Scene {
    kind: Option<AccelKind>,
    geometries: Geometries,
}

impl Scene {
    /// Builds `mesh` (on `nthreads`, the GIL released) and adds it as the next geometry.
    fn add(&mut self, py: Python<'_>, mesh: Mesh, nthreads: usize) -> PyResult<u32> {
        let kind = self.kind.unwrap_or_else(|| AccelKind::for_mesh(&mesh));
        let build = || kind.build(mesh, &BuildOptions::default());
        let tree = py
            .detach(|| threads::run(nthreads, build))?
            .map_err(value_error)?;
        self.geometries.push(tree).map_err(value_error)
    }

    /// Runs `query` on the rays of `rays` over `[tnear, tfar]`, on `nthreads`, the GIL
    /// released; the library's errors as `ValueError`.
    fn query<T: Send>(
        &self,
        py: Python<'_>,
        (rays, tnear, tfar): (&PyReadonlyArray2<'_, f32>, &LimitArg<'_>, &LimitArg<'_>),
        nthreads: usize,
        query: impl FnOnce(&Geometries, &Rays) -> Result<T, String> + Send,
    ) -> PyResult<T> {
        let rays = self::rays(rays, tnear, tfar)?;
        let geometries = &self.geometries;
        let answer = py.detach(|| threads::run(nthreads, || query(geometries, &rays)))?;
        answer.map_err(value_error)
    }
}

#[pymethods]
impl Scene {
    /// A scene without geometry; `kind` names the structure every geometry is built with.
    #[new]
    #[pyo3(signature = (kind=None))]
    fn new(kind: Option<&str>) -> PyResult<Self> {
        let kind = kind.map(kind_named).transpose()?;
        Ok(Self {
            kind,
            geometries: Geometries::new(),
        })
    }

    /// Adds the mesh of `(V, 3)` float32 vertices and `(F, 3)` uint32 triangles; its id.
    fn add_arrays(
        &mut self,
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f32>,
        triangles: PyReadonlyArray2<'_, u32>,
        nthreads: usize,
    ) -> PyResult<u32> {
        let vertices = data(&vertices)?.chunks_exact(3).map(Vec3::from_slice);
        let triangles = data(&triangles)?
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]]);
        let mesh = Mesh::new(vertices.collect(), triangles.collect()).map_err(mesh_error)?;
        self.add(py, mesh, nthreads)
    }

    /// Adds the mesh of an OBJ file; its id.
    fn add_obj(&mut self, py: Python<'_>, path: PathBuf, nthreads: usize) -> PyResult<u32> {
        let mesh = py.detach(|| Mesh::load_obj(&path)).map_err(mesh_error)?;
        self.add(py, mesh, nthreads)
    }

    /// Closest hits as flat arrays: `t`, geometry ids, triangle ids, `(u, v)` pairs and, if
    /// `normals`, world normals (else an empty array).
    #[allow(clippy::type_complexity)]
    fn cast_rays<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        tnear: LimitArg<'py>,
        tfar: LimitArg<'py>,
        nthreads: usize,
        normals: bool,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let rays = self::rays(&rays, &tnear, &tfar)?;
        let geometries = &self.geometries;
        let answer = py.detach(|| {
            threads::check(nthreads)?;
            let tables = normals.then(|| geometries.normal_tables());
            threads::run(nthreads, || geometries.closest(&rays, tables.as_deref()))
        })?;
        let c = answer.map_err(value_error)?;
        Ok((
            PyArray1::from_vec(py, c.t),
            PyArray1::from_vec(py, c.geometry),
            PyArray1::from_vec(py, c.primitive),
            PyArray1::from_vec(py, c.uv.into_flattened()),
            PyArray1::from_vec(py, c.normal.into_flattened()),
        ))
    }

    /// Whether each ray hits anything in its range.
    fn test_occlusions<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        tnear: LimitArg<'py>,
        tfar: LimitArg<'py>,
        nthreads: usize,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let arrays = (&rays, &tnear, &tfar);
        let answer = self.query(py, arrays, nthreads, |g, rays| g.occluded(rays))?;
        Ok(PyArray1::from_vec(py, answer))
    }

    /// The number of hits of each ray in its range.
    fn count_intersections<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        tnear: LimitArg<'py>,
        tfar: LimitArg<'py>,
        nthreads: usize,
    ) -> PyResult<Bound<'py, PyArray1<i32>>> {
        let arrays = (&rays, &tnear, &tfar);
        let answer = self.query(py, arrays, nthreads, |g, rays| g.count(rays))?;
        Ok(PyArray1::from_vec(py, answer))
    }

    /// Every hit of every ray, flat: splits, ray ids, geometry ids, triangle ids, `(u, v)`
    /// pairs, `t`.
    #[allow(clippy::type_complexity)]
    fn list_intersections<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        tnear: LimitArg<'py>,
        tfar: LimitArg<'py>,
        nthreads: usize,
    ) -> PyResult<(
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<u32>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let arrays = (&rays, &tnear, &tfar);
        let l = self.query(py, arrays, nthreads, |g, rays| g.list(rays))?;
        Ok((
            PyArray1::from_vec(py, l.splits),
            PyArray1::from_vec(py, l.ray),
            PyArray1::from_vec(py, l.geometry),
            PyArray1::from_vec(py, l.primitive),
            PyArray1::from_vec(py, l.uv),
            PyArray1::from_vec(py, l.t),
        ))
    }

    /// The scene as a cooked file's bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = py
            .detach(|| self.geometries.to_cooked())
            .map_err(cook_error)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// Writes the scene to a cooked file.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let write = || std::fs::write(&path, self.geometries.to_cooked()?).map_err(CookError::Io);
        py.detach(write).map_err(cook_error)
    }

    /// The scene of a cooked file's bytes.
    #[staticmethod]
    #[pyo3(signature = (data, kind=None))]
    fn from_bytes(py: Python<'_>, data: &[u8], kind: Option<&str>) -> PyResult<Self> {
        let kind = kind.map(kind_named).transpose()?;
        let geometries = py
            .detach(|| Geometries::from_cooked(data))
            .map_err(cook_error)?;
        Ok(Self { kind, geometries })
    }

    /// The scene of a cooked file.
    #[staticmethod]
    #[pyo3(signature = (path, kind=None))]
    fn load(py: Python<'_>, path: PathBuf, kind: Option<&str>) -> PyResult<Self> {
        let bytes = py
            .detach(|| std::fs::read(&path))
            .map_err(|e| PyOSError::new_err(format!("cannot read {}: {e}", path.display())))?;
        Self::from_bytes(py, &bytes, kind)
    }

    /// Geometries added or loaded.
    fn geometry_count(&self) -> usize {
        self.geometries.geometry_count()
    }

    /// Triangles over all geometries.
    fn triangle_count(&self) -> usize {
        self.geometries.triangle_count()
    }

    /// Each geometry's structure kind.
    fn kinds(&self) -> Vec<&'static str> {
        self.geometries.kinds()
    }
}

/// The kind called `name`, or a `ValueError` listing the kinds.
fn kind_named(name: &str) -> PyResult<AccelKind> {
    AccelKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = AccelKind::ALL.iter().map(|k| k.name()).collect();
        value_error(format!(
            "unknown structure kind {name:?} (kinds: {})",
            names.join(", ")
        ))
    })
}

/// An OBJ file's `(V, 3)` float32 vertices and `(F, 3)` uint32 triangles (polygons fanned).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn read_obj<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u32>>)> {
    let mesh = py.detach(|| Mesh::load_obj(&path)).map_err(mesh_error)?;
    let (vertices, triangles) = mesh.into_parts();
    let (v, f) = (vertices.len(), triangles.len());
    let vertices: Vec<f32> = vertices.iter().flat_map(|p| p.to_array()).collect();
    let triangles: Vec<u32> = triangles.into_iter().flatten().collect();
    Ok((
        PyArray1::from_vec(py, vertices).reshape([v, 3])?,
        PyArray1::from_vec(py, triangles).reshape([f, 3])?,
    ))
}

/// The module.
#[pymodule]
fn _raybatch(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(read_obj, m)?)?;
    let names = |cooks: bool| -> Vec<&str> {
        let kinds = AccelKind::ALL.into_iter().filter(|k| k.cooks() || !cooks);
        kinds.map(AccelKind::name).collect()
    };
    m.add("KINDS", names(false))?;
    m.add("COOKED_KINDS", names(true))?;
    m.add("INVALID_ID", INVALID_ID)?;
    m.add("FORMAT_VERSION", raybatch::cook::FORMAT_VERSION)?;
    Ok(())
}
