//! Choosing the triangles that define a node's box (its *cover*).
//!
//! A set of triangles has a box with 6 faces (min and max on each axis); each face is reached by
//! at least one triangle. The node keeps a few triangles that together reach all 6 faces: the
//! box of those few is the box of the whole set, so it can be recomputed from them alone, and
//! they are removed from the rest of the build. Fewer triangles mean fewer triangle tests at
//! every visit, so the cover is chosen greedily (the triangle reaching the most faces not yet
//! reached, 6 steps at most; optimal covers of 6 elements differ from greedy ones only rarely).
//!
//! With [`BoxVertices::Selected`] each kept triangle also names one corner, and the box must be
//! the box of those corners: a recomputation then reads one vertex per triangle, not three. A
//! corner can reach several faces (a vertex that is both the lowest and the leftmost), but each
//! triangle lends one corner, so such covers may need more triangles, and some sets have none
//! (a face reached only by a triangle that already lends another corner): those nodes fall back
//! to every corner.

use glam::{Vec3, Vec3A};

use super::BoxVertices;
use crate::bvh::build::{Box3A, Prim};
use crate::mesh::Mesh;

/// All six faces reached.
const ALL_FACES: u8 = 0b11_1111;

/// The cover chosen for a node: how many triangles it keeps (moved to the front of the set) and
/// their corner selectors, if the box comes from one corner per triangle.
pub(crate) struct Cover {
    pub(crate) count: usize,
    pub(crate) selectors: Option<Vec<u8>>,
}

/// Faces of `bounds` that `p` reaches: bit `a` for the min on axis `a`, `3 + a` for the max.
fn faces_reached(min: Vec3A, max: Vec3A, bounds: &Box3A) -> u8 {
    let low = min.cmpeq(bounds.min).bitmask() as u8;
    let high = max.cmpeq(bounds.max).bitmask() as u8;
    low | (high << 3)
}

/// Picks the cover of `prims` (whose box is `bounds`), moves it to the front of `prims` and
/// returns it. `prims` is not empty.
pub(crate) fn choose(
    prims: &mut [Prim],
    bounds: &Box3A,
    mesh: &Mesh,
    vertices: BoxVertices,
) -> Cover {
    if vertices == BoxVertices::Selected
        && let Some(picks) = by_corner(prims, bounds, mesh)
    {
        let selectors = picks.iter().map(|&(_, corner)| corner).collect();
        let indices: Vec<usize> = picks.iter().map(|&(i, _)| i).collect();
        move_to_front(prims, &indices);
        return Cover {
            count: picks.len(),
            selectors: Some(selectors),
        };
    }
    let picks = by_triangle(prims, bounds);
    let count = picks.len();
    move_to_front(prims, &picks);
    Cover {
        count,
        selectors: None,
    }
}

/// Greedy cover by whole triangles: indices into `prims`.
fn by_triangle(prims: &[Prim], bounds: &Box3A) -> Vec<usize> {
    let candidates: Vec<(usize, u8)> = prims
        .iter()
        .enumerate()
        .map(|(i, p)| (i, faces_reached(p.bounds.min, p.bounds.max, bounds)))
        .filter(|&(_, faces)| faces != 0)
        .collect();
    let mut picks = Vec::new();
    let mut reached = 0u8;
    while reached != ALL_FACES {
        let &(i, faces) = candidates
            .iter()
            .max_by_key(|&&(i, faces)| ((faces & !reached).count_ones(), std::cmp::Reverse(i)))
            .unwrap_or_else(|| unreachable!("every face of a set's box is reached by a member"));
        picks.push(i);
        reached |= faces;
    }
    picks
}

/// Greedy cover by one corner per triangle: `(index into prims, corner)`, or `None` if this
/// set has no such cover the greedy can find.
fn by_corner(prims: &[Prim], bounds: &Box3A, mesh: &Mesh) -> Option<Vec<(usize, u8)>> {
    let candidates: Vec<(usize, [u8; 3])> = prims
        .iter()
        .enumerate()
        .filter(|(_, p)| faces_reached(p.bounds.min, p.bounds.max, bounds) != 0)
        .map(|(i, p)| {
            let corners = mesh.triangle(p.id);
            let faces = corners.map(|c: Vec3| faces_reached(c.into(), c.into(), bounds));
            (i, faces)
        })
        .collect();
    let mut picks: Vec<(usize, u8)> = Vec::new();
    let mut reached = 0u8;
    while reached != ALL_FACES {
        let best = candidates
            .iter()
            .filter(|(i, _)| picks.iter().all(|&(p, _)| p != *i))
            .flat_map(|&(i, faces)| (0..3u8).map(move |c| (i, c, faces[c as usize])))
            .max_by_key(|&(i, c, faces)| {
                let new = (faces & !reached).count_ones();
                (new, std::cmp::Reverse((i, c)))
            })?;
        let (i, corner, faces) = best;
        if faces & !reached == 0 {
            return None;
        }
        picks.push((i, corner));
        reached |= faces;
    }
    Some(picks)
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
    use crate::bvh::build::prims_of;
    use crate::test_support::bunny;

    fn box_of(prims: &[Prim]) -> Box3A {
        prims.iter().fold(
            Box3A {
                min: Vec3A::INFINITY,
                max: Vec3A::NEG_INFINITY,
            },
            |b, p| b.union(p.bounds),
        )
    }

    /// On many subsets of the bunny, the cover's box (whole triangles, or the selected corners)
    /// is exactly the set's box, and the cover is at most 6 triangles.
    #[test]
    fn covers_give_the_exact_box() {
        let mesh = bunny();
        let all = prims_of(&mesh);
        for (start, len) in [(0, 2), (10, 3), (100, 9), (0, 1000), (5, all.len() - 5)] {
            for vertices in [BoxVertices::All, BoxVertices::Selected] {
                let mut set = all[start..start + len].to_vec();
                let bounds = box_of(&set);
                let cover = choose(&mut set, &bounds, &mesh, vertices);
                assert!((1..=6).contains(&cover.count));
                let kept = &set[..cover.count];
                let b = match &cover.selectors {
                    Some(sel) => kept.iter().zip(sel).fold(
                        Box3A {
                            min: Vec3A::INFINITY,
                            max: Vec3A::NEG_INFINITY,
                        },
                        |b, (p, &c)| b.grow(mesh.triangle(p.id)[c as usize].into()),
                    ),
                    None => box_of(kept),
                };
                assert_eq!(b.min, bounds.min);
                assert_eq!(b.max, bounds.max);
                let mut ids: Vec<u32> = set.iter().map(|p| p.id).collect();
                ids.sort_unstable();
                let expected: Vec<u32> = all[start..start + len].iter().map(|p| p.id).collect();
                assert_eq!(ids, expected, "the set is only reordered");
            }
        }
    }
}
