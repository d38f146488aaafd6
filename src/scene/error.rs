//! [`SceneError`]: every way a scene edit can be refused. A refused edit leaves the scene as it
//! was (every check runs before anything changes), and no scene call panics on user data.

use crate::bvh::BuildError;
use crate::mesh::MeshError;

/// Why a scene was not built or an edit was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneError {
    /// A rotation or translation component is NaN or infinite.
    NonFiniteTransform,
    /// The rotation is not a unit quaternion (a scale or a shear): its squared length is
    /// `norm2`, further from 1 than [`crate::scene::RIGID_TOLERANCE`].
    NonRigidTransform {
        /// The quaternion's squared length.
        norm2: f32,
    },
    /// A scale outside [`crate::scene::Rigid::SCALES`], or NaN.
    BadScale {
        /// The scale given.
        scale: f32,
    },
    /// An instance names a mesh the scene does not hold.
    NoSuchMesh {
        /// The mesh index given.
        mesh: usize,
        /// Meshes in the scene.
        meshes: usize,
    },
    /// An edit names an instance the scene does not hold.
    NoSuchInstance {
        /// The instance index given.
        instance: usize,
        /// Instances in the scene.
        instances: usize,
    },
    /// An edit names an instance that was removed ([`crate::scene::Scene::remove_instance`]).
    RemovedInstance {
        /// The instance index given.
        instance: usize,
    },
    /// The instances hold more triangles in total than global ids can number
    /// ([`crate::mesh::MAX_TRIANGLES`]).
    TooManyTriangles {
        /// Triangles over all instances.
        count: u64,
    },
    /// A mesh's tree could not be built.
    Build(BuildError),
    /// New vertices for a deforming mesh were rejected (NaN, too large).
    Mesh(MeshError),
    /// New vertices for a deforming mesh do not match it: the vertex count differs.
    VertexCountChanged {
        /// Vertices the mesh has.
        expected: usize,
        /// Vertices given.
        given: usize,
    },
    /// A triangle degenerate when the tree was built (so the tree never tests it) has an area
    /// after the deformation: the tree must be rebuilt to answer exactly.
    NewlyValidTriangle {
        /// The triangle's id.
        triangle: u32,
    },
    /// A triangle the tree tests has no area after the deformation (degenerate triangles are
    /// never hit): the tree must be rebuilt to answer exactly.
    NewlyDegenerateTriangle {
        /// The triangle's id.
        triangle: u32,
    },
    /// The mesh's tree cannot be refitted in place (only the full-node AABB tree can; other
    /// kinds store or recompute boxes from data a deformation invalidates): rebuild it.
    NotRefittable {
        /// The tree kind's name.
        kind: &'static str,
    },
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneError::NonFiniteTransform => f.write_str("transform has a NaN or infinity"),
            SceneError::NonRigidTransform { norm2 } => write!(
                f,
                "transform is not rigid: rotation quaternion has squared length {norm2}"
            ),
            SceneError::BadScale { scale } => {
                write!(f, "scale {scale} is outside 2^-20..=2^20")
            }
            SceneError::NoSuchMesh { mesh, meshes } => {
                write!(f, "mesh {mesh} does not exist (the scene has {meshes})")
            }
            SceneError::NoSuchInstance {
                instance,
                instances,
            } => write!(
                f,
                "instance {instance} does not exist (the scene has {instances})"
            ),
            SceneError::RemovedInstance { instance } => {
                write!(f, "instance {instance} was removed from the scene")
            }
            SceneError::TooManyTriangles { count } => {
                write!(
                    f,
                    "{count} triangles over all instances: too many for 32-bit ids"
                )
            }
            SceneError::Build(e) => write!(f, "building a mesh's tree: {e}"),
            SceneError::Mesh(e) => write!(f, "deformed mesh: {e}"),
            SceneError::VertexCountChanged { expected, given } => write!(
                f,
                "deformed mesh has {given} vertices, the mesh has {expected}"
            ),
            SceneError::NewlyValidTriangle { triangle } => write!(
                f,
                "triangle {triangle} was degenerate when the tree was built and has an area now; rebuild the tree"
            ),
            SceneError::NewlyDegenerateTriangle { triangle } => write!(
                f,
                "triangle {triangle} has no area after the deformation; rebuild the tree"
            ),
            SceneError::NotRefittable { kind } => {
                write!(f, "a {kind} tree cannot be refitted; rebuild it")
            }
        }
    }
}

impl std::error::Error for SceneError {}

impl From<BuildError> for SceneError {
    fn from(e: BuildError) -> Self {
        SceneError::Build(e)
    }
}

impl From<MeshError> for SceneError {
    fn from(e: MeshError) -> Self {
        SceneError::Mesh(e)
    }
}
