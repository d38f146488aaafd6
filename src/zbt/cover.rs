//! Choosing the triangles that define a node's box (its *cover*).
//!
//! A set of triangles has a box with 6 faces (min and max on each axis); each face is reached by
//! at least one triangle. A node keeps a few triangles that together reach every face it must
//! define itself (the faces it does not inherit from its parent, see [`super::build`]): the box
//! of those few is then the set's box on those faces, so it can be recomputed from them alone,
//! and they are taken out of the rest of the build. Every visit tests them, so the cover is
//! chosen greedily small (the triangle reaching the most faces not yet reached, 6 steps at most;
//! optimal covers of 6 elements rarely differ from greedy ones).

use crate::bvh::build::{Box3A, Prim};

/// Faces of `bounds` that a triangle with box `(min, max)` reaches: bit `a` for the min on axis
/// `a`, `3 + a` for the max.
pub(crate) fn faces_reached(p: &Box3A, bounds: &Box3A) -> u8 {
    let low = p.min.cmpeq(bounds.min).bitmask() as u8;
    let high = p.max.cmpeq(bounds.max).bitmask() as u8;
    low | (high << 3)
}

/// Picks a cover of the faces `needed` of `prims`' box `bounds` (at least one triangle, so that
/// the node has a position), moves it to the front of `prims` and returns its size. `prims` is
/// not empty.
pub(crate) fn choose(prims: &mut [Prim], bounds: &Box3A, needed: u8) -> usize {
    let candidates: Vec<(usize, u8)> = prims
        .iter()
        .enumerate()
        .map(|(i, p)| (i, faces_reached(&p.bounds, bounds) & needed))
        .filter(|&(_, faces)| faces != 0)
        .collect();
    let mut picks = Vec::new();
    let mut reached = 0u8;
    while reached != needed {
        let &(i, faces) = candidates
            .iter()
            .max_by_key(|&&(i, faces)| ((faces & !reached).count_ones(), std::cmp::Reverse(i)))
            .unwrap_or_else(|| unreachable!("every face of a set's box is reached by a member"));
        picks.push(i);
        reached |= faces;
    }
    if picks.is_empty() {
        picks.push(0);
    }
    move_to_front(prims, &picks);
    picks.len()
}

/// Moves `prims[picks[k]]` to position `k`, in pick order; the others keep the rest.
fn move_to_front(prims: &mut [Prim], picks: &[usize]) {
    let chosen: Vec<Prim> = picks.iter().map(|&i| prims[i]).collect();
    // Swapping in ascending index order gathers the picked set at the front: the k-th smallest
    // pick is at or beyond k, so no swap moves a pick that is still to be placed.
    let mut ascending = picks.to_vec();
    ascending.sort_unstable();
    for (k, &i) in ascending.iter().enumerate() {
        prims.swap(k, i);
    }
    prims[..chosen.len()].copy_from_slice(&chosen);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::{Extent, prims_of};
    use crate::test_support::bunny;

    /// On many subsets of the bunny and face masks, the cover reaches exactly the asked faces of
    /// the set's box, has at most 6 triangles (1 when no face is asked), and the set is only
    /// reordered.
    #[test]
    fn covers_reach_the_asked_faces() {
        let mesh = bunny();
        let all = prims_of(&mesh, false);
        for (start, len) in [(0, 2), (10, 3), (100, 9), (0, 1000), (5, all.len() - 5)] {
            for needed in [0b11_1111, 0b00_0001, 0b10_0100, 0] {
                let mut set = all[start..start + len].to_vec();
                let bounds = Extent::of(&set).bounds;
                let count = choose(&mut set, &bounds, needed);
                assert!((1..=6).contains(&count));
                let reached = set[..count]
                    .iter()
                    .fold(0, |r, p| r | faces_reached(&p.bounds, &bounds));
                assert_eq!(reached & needed, needed);
                if needed == 0 {
                    assert_eq!(count, 1);
                }
                let mut ids: Vec<u32> = set.iter().map(|p| p.id).collect();
                ids.sort_unstable();
                let expected: Vec<u32> = all[start..start + len].iter().map(|p| p.id).collect();
                assert_eq!(ids, expected, "the set is only reordered");
            }
        }
    }
}
