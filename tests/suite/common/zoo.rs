//! The structure zoo: every structure of [`AccelKind::ALL`] built with every leaf size and
//! child ordering, each behind a [`Tested`] with a name saying how it was built. A structure
//! added to `AccelKind` is in every zoo, so every test that walks the zoo covers it.

use std::sync::Arc;

use raybatch::{
    AccelKind, BatchQueries, BuildOptions, ChildOrdering, Footprint, Hit, Kernel, Mesh, Ray,
    RayQueries,
};

/// Leaf sizes every structure is built with.
pub const LEAF_SIZES: [u32; 3] = [1, 4, 16];

/// Structures in [`all_structures`]: every kind x leaf size x ordering (9 per kind).
pub const ZOO_SIZE: usize = AccelKind::ALL.len() * LEAF_SIZES.len() * ChildOrdering::ALL.len();

/// What the tests ask of a structure: the queries and the footprint (a catalog kind, or a
/// structure outside the catalog such as the quantized-vertex tree).
pub trait Tested: RayQueries + BatchQueries + Footprint + Sync {}

impl<T: RayQueries + BatchQueries + Footprint + Sync> Tested for T {}

/// One built structure and a name saying how it was built (`aabb/leaf4/pns`).
pub struct Built {
    pub name: String,
    pub accel: Box<dyn Tested>,
}

impl Built {
    /// `for_each_hit` (watertight kernel), the hits collected in callback order.
    pub fn each_hit(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.accel
            .for_each_hit_with(ray, Kernel::Watertight, &mut |h| hits.push(h));
        hits
    }

    /// `for_each_hit_with`, the hits collected in callback order.
    pub fn each_hit_with(&self, ray: &Ray, kernel: Kernel) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.accel
            .for_each_hit_with(ray, kernel, &mut |h| hits.push(h));
        hits
    }
}

/// Builds `kind` over `mesh` with `options`, panicking with `name` if the build fails.
pub fn build(mesh: &Arc<Mesh>, kind: AccelKind, options: &BuildOptions, name: String) -> Built {
    let accel = kind
        .build(mesh.clone(), options)
        .unwrap_or_else(|e| panic!("{name}: build failed: {e}"));
    Built {
        name,
        accel: Box::new(accel),
    }
}

/// Every combination of the chosen kinds, leaf sizes and orderings, kind-major (then leaf
/// size, then ordering).
pub fn structures_with(
    mesh: &Mesh,
    kinds: &[AccelKind],
    leaves: &[u32],
    orderings: &[ChildOrdering],
) -> Vec<Built> {
    let mesh = Arc::new(mesh.clone());
    let mut out = Vec::new();
    for &kind in kinds {
        for &leaf in leaves {
            for &ordering in orderings {
                let options = BuildOptions::default()
                    .with_leaf_size(leaf)
                    .with_ordering(ordering);
                let name = format!("{}/leaf{leaf}/{}", kind.name(), ordering.name());
                out.push(build(&mesh, kind, &options, name));
            }
        }
    }
    out
}

/// The whole zoo: [`AccelKind::ALL`] x leaf {1, 4, 16} x {fixed, split-axis, PNS}
/// ([`ZOO_SIZE`] structures).
pub fn all_structures(mesh: &Mesh) -> Vec<Built> {
    let zoo = structures_with(mesh, &AccelKind::ALL, &LEAF_SIZES, &ChildOrdering::ALL);
    assert_eq!(zoo.len(), ZOO_SIZE);
    zoo
}
