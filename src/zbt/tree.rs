//! [`ZeroByteTree`]: a mesh whose triangle order and index bits are the tree.
//!
//! A zero-byte tree is [`PackedTree`] without a top level (see [`super::hybrid`]): one chunk
//! holding the whole mesh, whose root computes its own box. Traversal, boxes, accessors and
//! accounting are written once there; this file adds the zero-byte tree's build, with its own
//! triangle limit.

use super::hybrid::PackedTree;
use super::layout::MAX_TRIANGLES;
use super::{Rejected, ZbtError, ZbtOptions, check_common};
use crate::mesh::Mesh;

/// A zero-byte AABB tree (see [the module docs](super)): the mesh, reordered, and nothing else.
pub type ZeroByteTree = PackedTree<false>;

impl ZeroByteTree {
    /// Builds the tree by reordering `mesh`'s triangles; returns it with the permutation
    /// (`permutation[new id] = original id`). On error the mesh is handed back unchanged.
    ///
    /// ```
    /// use raybatch::zbt::{ZbtOptions, ZeroByteTree};
    /// use raybatch::{Mesh, Ray, RayQueries, glam::Vec3};
    ///
    /// let mesh = Mesh::new(
    ///     vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)],
    ///     vec![[0, 1, 2]],
    /// )?;
    /// let materials = vec!["stone"];
    /// let (tree, permutation) = ZeroByteTree::build(mesh, &ZbtOptions::default())?;
    /// // Reorder per-triangle data once, so that hit ids index it directly.
    /// let materials: Vec<&str> = permutation.iter().map(|&id| materials[id as usize]).collect();
    /// let hit = tree.cast_ray(&Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Z)).unwrap();
    /// assert_eq!(materials[hit.triangle as usize], "stone");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn build(mesh: Mesh, options: &ZbtOptions) -> Result<(Self, Vec<u32>), Rejected> {
        if let Err(error) = check(&mesh, options) {
            return Err(Rejected { error, mesh });
        }
        Ok(Self::build_checked(mesh, options, usize::MAX))
    }

    /// The options the tree was built with.
    pub fn options(&self) -> &ZbtOptions {
        &self.options.zbt
    }
}

/// The limits of a zero-byte tree (see [`super::layout`]).
fn check(mesh: &Mesh, options: &ZbtOptions) -> Result<(), ZbtError> {
    check_common(mesh, options.leaf_size)?;
    if mesh.triangle_count() > MAX_TRIANGLES {
        return Err(ZbtError::TooManyTriangles {
            count: mesh.triangle_count(),
            max: MAX_TRIANGLES,
        });
    }
    Ok(())
}
