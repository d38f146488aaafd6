//! Filtering instances by layer, as game engines do: each instance has a mask of layers
//! ([`super::Instance::mask`]), a query a mask of the layers it sees, and an instance
//! takes part only if the two share a bit. The filter is applied in the top-level tree (each
//! node knows the union of its instances' masks), so a filtered-out instance costs no
//! transform and no triangle test.
//!
//! [`SceneView`] is a scene seen through one query mask; like the scene itself it answers every
//! per-ray and batched query.

use crate::scene::world::Scene;

/// A scene seen by queries with layer mask `mask` (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) mask: u32,
}

impl Scene {
    /// The scene as seen by queries on layers `mask`: instances whose mask shares no bit with
    /// it are skipped.
    pub fn filtered(&self, mask: u32) -> SceneView<'_> {
        SceneView { scene: self, mask }
    }
}

impl<'a> SceneView<'a> {
    /// The scene.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The query's layer mask.
    pub fn mask(&self) -> u32 {
        self.mask
    }
}
