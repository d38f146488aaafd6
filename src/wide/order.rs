//! A wide node's slots as built from its children: their child words and, per direction
//! octant, the order a walk pushes them in (precomputed node sorting), which every
//! layout stores and the walks read back with [`order_slots`].

use glam::Vec3;

use crate::bvh::ordering::octant_diagonal;
use crate::geom::Aabb;

/// The child words of `children` in slots `0..`, the others 0 (which no leaf word is).
pub(crate) fn child_words<const W: usize>(children: &[(Aabb, u32)]) -> [u32; W] {
    std::array::from_fn(|slot| children.get(slot).map_or(0, |&(_, word)| word))
}

/// The slots of order word `order` of a node of `width` slots, nearest first (see
/// [`octant_orders`]); every slot once.
#[inline(always)]
pub(crate) fn order_slots(order: u32, width: usize) -> impl DoubleEndedIterator<Item = usize> {
    let bits = slot_bits(width);
    (0..width as u32).map(move |k| (order >> (bits * k)) as usize & (width - 1))
}

/// Bits of a slot number in an order word of a node of `width` slots.
const fn slot_bits(width: usize) -> u32 {
    width.trailing_zeros()
}

/// The order word listing a node's `width` slots in slot order.
pub(crate) const fn slot_order(width: usize) -> u32 {
    let mut word = 0;
    let mut slot = 0;
    while slot < width {
        word |= (slot as u32) << (slot_bits(width) * slot as u32);
        slot += 1;
    }
    word
}

/// Per direction octant, the order word of a node of `width` slots whose used slots
/// `0..children.len()` hold `children`: the used slots sorted by the projection of their boxes'
/// centres on the octant's diagonal (ties by slot), then the unused ones, position `k` in bits
/// `k * b..(k + 1) * b` for `b = log2(width)` (read back by [`order_slots`]). A walk pushes the
/// slots in this order (precomputed node sorting), so every position names each slot once.
pub(crate) fn octant_orders(children: &[(Aabb, u32)], width: usize) -> [u32; 8] {
    debug_assert!(width.is_power_of_two() && children.len() <= width && width <= 8);
    let mut centres = [Vec3::ZERO; 8];
    for (centre, (bounds, _)) in centres.iter_mut().zip(children) {
        *centre = bounds.center();
    }
    let used = children.len();
    std::array::from_fn(|octant| {
        let diagonal = octant_diagonal(octant as u32);
        // Each slot's sort key above its number (so that ties keep slot order), unused slots
        // last; a sorting network orders them without branches (a sort's unpredictable
        // branches made the orders a quarter of loading a cooked tree).
        let mut keys: [u64; 8] = std::array::from_fn(|slot| {
            let key = if slot < used {
                u64::from(total_order_key(centres[slot].dot(diagonal)) as u32 ^ 0x8000_0000)
            } else {
                u64::from(u32::MAX)
            };
            key << 32 | slot as u64
        });
        sort_eight(&mut keys);
        keys[..width].iter().rev().fold(0, |word, &key| {
            (word << slot_bits(width)) | (key & 7) as u32
        })
    })
}

/// Sorts `keys` with a sorting network: 19 compare-exchanges in six rounds, without a branch.
#[inline(always)]
fn sort_eight(keys: &mut [u64; 8]) {
    #[inline(always)]
    fn exchange(keys: &mut [u64; 8], a: usize, b: usize) {
        let (low, high) = (keys[a].min(keys[b]), keys[a].max(keys[b]));
        keys[a] = low;
        keys[b] = high;
    }
    for (a, b) in [(0, 2), (1, 3), (4, 6), (5, 7)] {
        exchange(keys, a, b);
    }
    for (a, b) in [(0, 4), (1, 5), (2, 6), (3, 7)] {
        exchange(keys, a, b);
    }
    for (a, b) in [(0, 1), (2, 3), (4, 5), (6, 7)] {
        exchange(keys, a, b);
    }
    for (a, b) in [(2, 4), (3, 5), (1, 4), (3, 6)] {
        exchange(keys, a, b);
    }
    for (a, b) in [(1, 2), (3, 4), (5, 6)] {
        exchange(keys, a, b);
    }
}

/// An integer whose order is [`f32::total_cmp`]'s order of `x`.
fn total_order_key(x: f32) -> i32 {
    let bits = x.to_bits() as i32;
    bits ^ (((bits >> 31) as u32) >> 1) as i32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// The orders as a stable sort by `total_cmp` gives them.
    fn sorted_orders(children: &[(Aabb, u32)], width: usize) -> [u32; 8] {
        let centres: Vec<Vec3> = children.iter().map(|(b, _)| b.center()).collect();
        std::array::from_fn(|octant| {
            let diagonal = octant_diagonal(octant as u32);
            let mut slots: Vec<usize> = (0..children.len()).collect();
            slots.sort_by(|&a, &b| {
                centres[a]
                    .dot(diagonal)
                    .total_cmp(&centres[b].dot(diagonal))
            });
            slots.extend(children.len()..width);
            slots
                .iter()
                .rev()
                .fold(0, |word, &slot| (word << slot_bits(width)) | slot as u32)
        })
    }

    /// Counting gives the stable sort's orders, ties and signed zeros included.
    #[test]
    fn orders_by_counting_are_the_stable_sort() {
        let mut rng = TestRng::new(3);
        for case in 0..20_000 {
            let width = if case % 2 == 0 { 4 } else { 8 };
            let used = 1 + case % width;
            let children: Vec<(Aabb, u32)> = (0..used)
                .map(|slot| {
                    // Few distinct centres, so that ties are common; zeros of both signs.
                    let c = rng.vec3(2.0).round() * if case % 3 == 0 { -0.0 } else { 1.0 };
                    let half = rng.vec3(1.0).abs().round();
                    (Aabb::new(c - half, c + half), slot as u32 + 1)
                })
                .collect();
            assert_eq!(
                octant_orders(&children, width),
                sorted_orders(&children, width),
                "{children:?}"
            );
        }
    }

    #[test]
    fn the_key_orders_as_total_cmp() {
        let values = [
            f32::NEG_INFINITY,
            -2.5,
            -0.0,
            0.0,
            1e-40,
            3.0,
            f32::INFINITY,
        ];
        for a in values {
            for b in values {
                assert_eq!(total_order_key(a).cmp(&total_order_key(b)), a.total_cmp(&b));
            }
        }
    }
}
