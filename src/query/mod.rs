//! Ray queries: closest hit, any hit (occlusion) and all hits.
//!
//! [`single`] is the reference traversal, one ray at a time, written once against
//! [`crate::tree::Bvh`] so that every tree gets it; [`brute_force`] tests every triangle and is
//! the reference the tests compare trees against.
//!
//! **Tie rule.** When several triangles are hit at the same `t` (a ray through a shared edge or
//! vertex, or coplanar overlapping triangles), the closest hit is the one with the **lowest
//! triangle id**. Every tree, ordering, kernel and batch size follows it, so answers never
//! depend on the visiting order. Traversal keeps boxes whose entry distance equals the current
//! best `t` (they may hold an equal-`t` triangle with a lower id) and accepts a triangle hit
//! when `(t, id)` is lexicographically smaller than the best so far.

pub mod batch;
pub mod brute_force;
pub mod single;

/// A ray's hit on a triangle: `p = origin + t * dir = (1 - u - v) * v0 + u * v1 + v * v2`,
/// where `v0, v1, v2` are the corners of triangle `triangle` in the order the mesh lists them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Triangle id: its index in the mesh's triangle array.
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

impl Hit {
    /// The tie rule: smaller `t` wins, and on equal `t` the lower triangle id.
    #[inline(always)]
    pub fn is_before(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.triangle < other.triangle)
    }

    /// Sorts hits by `t`, then triangle id (the order [`single::RayQueries::all_hits`] returns).
    pub fn sort(hits: &mut [Hit]) {
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    }
}
