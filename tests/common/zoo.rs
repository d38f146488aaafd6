//! The structure zoo: every structure of [`AccelKind::ALL`] built with every leaf size and
//! child ordering, each behind [`AnyAccel`] with a name saying how it was built. A structure
//! added to `AccelKind` is in every zoo, so every test that walks the zoo covers it.

use std::sync::Arc;

use raybatch::{AccelKind, AnyAccel, BuildOptions, ChildOrdering, Hit, Kernel, Mesh, Ray};

/// Leaf sizes every structure is built with.
pub const LEAF_SIZES: [u32; 3] = [1, 4, 16];

/// Structures in [`all_structures`]: every kind x leaf size x ordering (9 per kind).
pub const ZOO_SIZE: usize = AccelKind::ALL.len() * LEAF_SIZES.len() * ChildOrdering::ALL.len();

/// One built structure and a name saying how it was built (`aabb/leaf4/pns`).
pub struct Structure {
    pub name: String,
    pub accel: AnyAccel,
}

impl Structure {
    /// `for_each_hit` (watertight kernel), the hits collected in callback order.
    pub fn each_hit(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.accel.for_each_hit(ray, |h| hits.push(h));
        hits
    }

    /// `for_each_hit_with`, the hits collected in callback order.
    pub fn each_hit_with(&self, ray: &Ray, kernel: Kernel) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.accel.for_each_hit_with(ray, kernel, |h| hits.push(h));
        hits
    }
}

/// Builds `kind` over `mesh` with `options`, panicking with `name` if the build fails.
pub fn build(mesh: &Arc<Mesh>, kind: AccelKind, options: &BuildOptions, name: String) -> Structure {
    let accel = kind
        .build(mesh.clone(), options)
        .unwrap_or_else(|e| panic!("{name}: build failed: {e}"));
    Structure { name, accel }
}

/// Every combination of the chosen kinds, leaf sizes and orderings, kind-major (then leaf
/// size, then ordering).
pub fn structures_with(
    mesh: &Mesh,
    kinds: &[AccelKind],
    leaves: &[u32],
    orderings: &[ChildOrdering],
) -> Vec<Structure> {
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
pub fn all_structures(mesh: &Mesh) -> Vec<Structure> {
    let zoo = structures_with(mesh, &AccelKind::ALL, &LEAF_SIZES, &ChildOrdering::ALL);
    assert_eq!(zoo.len(), ZOO_SIZE);
    zoo
}
