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
        let along = centres.map(|centre| centre.dot(diagonal));
        // A stable sort (no allocation at this size): equal projections keep slot order.
        let mut slots: [usize; 8] = std::array::from_fn(|slot| slot);
        slots[..used].sort_by(|&a, &b| along[a].total_cmp(&along[b]));
        slots[..width]
            .iter()
            .rev()
            .fold(0, |word, &slot| (word << slot_bits(width)) | slot as u32)
    })
}
