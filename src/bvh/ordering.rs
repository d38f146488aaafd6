//! Precomputed node sorting (PNS): the child visit order for every ray octant, in one
//! byte per internal node.
//!
//! Visiting the nearer child first lets a closest-hit query shrink its ray early and skip the
//! farther subtree. Instead of computing distances at run time, the build decides, for each of
//! the 8 direction octants, which child is nearer, and stores one bit per octant: bit `o` set
//! means "visit the second child first for rays in octant `o`". The ray computes its octant mask
//! `1 << octant(dir)` once ([`crate::geom::octant`]); at each node the order is a single AND.
//!
//! Three ways to fill the byte are kept so that they can be measured against each other:
//! - [`ChildOrdering::Fixed`]: all zeros, first child always first (no sorting).
//! - [`ChildOrdering::SplitAxis`]: compare the children's centres along the build's split axis
//!   only, by the sign of the ray direction on that axis (the classic kd-tree order).
//! - [`ChildOrdering::Pns`]: project the children's centres on each octant's diagonal
//!   `(+-1, +-1, +-1)` and put the nearer one first (precomputed node sorting proper).
//!
//! The ordering only changes speed, never results: closest-hit answers follow the tie rule, so
//! they do not depend on the visiting order.

use glam::Vec3;

use crate::geom::Aabb;

/// How internal nodes order their children.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ChildOrdering {
    /// No sorting: first child first.
    Fixed,
    /// Sign of the ray direction along the node's split axis.
    SplitAxis,
    /// Precomputed node sorting on the octant diagonals (the default).
    #[default]
    Pns,
}

impl ChildOrdering {
    /// Every ordering.
    pub const ALL: [ChildOrdering; 3] = [
        ChildOrdering::Fixed,
        ChildOrdering::SplitAxis,
        ChildOrdering::Pns,
    ];

    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            ChildOrdering::Fixed => "fixed",
            ChildOrdering::SplitAxis => "split-axis",
            ChildOrdering::Pns => "pns",
        }
    }
}

/// The diagonal of octant `o` (bit 0: x negative, bit 1: y negative, bit 2: z negative).
pub(crate) fn octant_diagonal(o: u32) -> Vec3 {
    let sign = |bit: u32| if o & (1 << bit) != 0 { -1.0 } else { 1.0 };
    Vec3::new(sign(0), sign(1), sign(2))
}

/// The ordering byte of a node whose children have boxes `first` and `second`.
pub fn ordering_byte(
    ordering: ChildOrdering,
    first: &Aabb,
    second: &Aabb,
    split_axis: usize,
) -> u8 {
    let delta = first.center() - second.center();
    let delta = match ordering {
        ChildOrdering::Fixed => return 0,
        ChildOrdering::SplitAxis => {
            let mut axis_only = Vec3::ZERO;
            axis_only[split_axis] = delta[split_axis];
            axis_only
        }
        ChildOrdering::Pns => delta,
    };
    (0..8)
        .filter(|&o| delta.dot(octant_diagonal(o)) > 0.0)
        .fold(0u8, |byte, o| byte | (1 << o))
}

/// True if a ray with octant mask `octant_mask` visits the second child first.
#[inline(always)]
pub fn second_child_first(order: u8, octant_mask: u8) -> bool {
    order & octant_mask != 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::octant;

    #[test]
    fn nearer_child_first_for_each_octant() {
        // First child at +x: rays going -x (octant bit 0) should visit it first, +x the second.
        let first = Aabb::new(Vec3::new(2.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0));
        let second = Aabb::new(Vec3::ZERO, Vec3::ONE);
        for ordering in [ChildOrdering::Pns, ChildOrdering::SplitAxis] {
            let byte = ordering_byte(ordering, &first, &second, 0);
            let mask = |d: Vec3| 1u8 << octant(d);
            assert!(second_child_first(byte, mask(Vec3::new(1.0, 0.1, 0.1))));
            assert!(!second_child_first(byte, mask(Vec3::new(-1.0, 0.1, 0.1))));
        }
        assert_eq!(ordering_byte(ChildOrdering::Fixed, &first, &second, 0), 0);
    }
}
