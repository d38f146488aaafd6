//! Mailboxing: a triangle stored in several cells is tested at most once per ray.
//!
//! Classic "time stamping" keeps one stamp per triangle (the number of the ray that last
//! tested it); measured on the 1M-triangle terrain, those stamps (4 MB per thread) cost a
//! cache miss per test. A ray tests few triangles, so this mailbox keeps only *those*: a small
//! open-addressing set of `(ray number, triangle)` slots, in L1. A slot whose ray number is not
//! the current ray's is free, so a new ray takes the next number and clears nothing (on
//! wrap-around, after 2^32 rays, the slots are zeroed once). The set doubles when it is half
//! full and keeps its size for the next rays, so a thread's mailbox grows to its longest ray's
//! needs and never depends on the mesh size. Ray numbers come from the one counter of the
//! thread's mailbox, so every grid the thread queries can share it: a slot left by another
//! grid's ray is always an older number.
//!
//! Cells mark the references of triangles stored in one cell only (the `SHARED` bit clear): those
//! cannot be met twice (each cell is visited once per ray) and skip the set.

/// Bit set in a cell's triangle reference when the triangle is stored in more than one cell.
pub(crate) const SHARED: u32 = 1 << 31;

/// Slots of a new mailbox (grown on demand).
const INITIAL_SLOTS: usize = 64;

/// The triangles the current ray has tested (see the module docs): the `Accel::Scratch` of
/// the grids.
#[derive(Debug, Default)]
pub struct Mailbox {
    /// `(ray number, triangle id)`; free unless the number is the current ray's.
    slots: Vec<(u32, u32)>,
    ray: u32,
    /// Slots the current ray holds.
    used: usize,
}

impl Mailbox {
    /// Starts a new ray.
    #[inline]
    pub(crate) fn next_ray(&mut self) {
        if self.slots.is_empty() {
            self.slots = vec![(0, 0); INITIAL_SLOTS];
        }
        self.ray = self.ray.wrapping_add(1);
        if self.ray == 0 {
            self.slots.fill((0, 0));
            self.ray = 1;
        }
        self.used = 0;
    }

    /// True if the current ray meets the triangle of cell reference `reference` for the first
    /// time (always for a triangle stored in one cell only).
    #[inline(always)]
    pub(crate) fn first_visit(&mut self, reference: u32) -> bool {
        if reference & SHARED == 0 {
            return true;
        }
        let id = reference & !SHARED;
        let mask = self.slots.len() - 1;
        let mut i = slot_of(id, mask);
        loop {
            let (ray, held) = self.slots[i];
            if ray != self.ray {
                self.slots[i] = (self.ray, id);
                self.used += 1;
                if self.used * 2 > self.slots.len() {
                    self.grow();
                }
                return true;
            }
            if held == id {
                return false;
            }
            i = (i + 1) & mask;
        }
    }

    /// Doubles the set, keeping the current ray's triangles.
    #[cold]
    fn grow(&mut self) {
        let ray = self.ray;
        let kept: Vec<u32> = self
            .slots
            .iter()
            .filter(|s| s.0 == ray)
            .map(|s| s.1)
            .collect();
        self.slots = vec![(0, 0); self.slots.len() * 2];
        let mask = self.slots.len() - 1;
        for id in kept {
            let mut i = slot_of(id, mask);
            while self.slots[i].0 == ray {
                i = (i + 1) & mask;
            }
            self.slots[i] = (ray, id);
        }
    }
}

/// The home slot of triangle `id` (Fibonacci hashing: neighbouring ids spread out).
#[inline(always)]
fn slot_of(id: u32, mask: usize) -> usize {
    (id.wrapping_mul(0x9e37_79b9) >> 8) as usize & mask
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_triangles_are_seen_once_per_ray() {
        let mut m = Mailbox::default();
        m.next_ray();
        assert!(m.first_visit(2 | SHARED));
        assert!(!m.first_visit(2 | SHARED));
        // Unshared references never touch the set.
        assert!(m.first_visit(3) && m.first_visit(3));
        m.next_ray();
        assert!(m.first_visit(2 | SHARED));
    }

    #[test]
    fn the_set_grows_and_keeps_what_it_holds() {
        let mut m = Mailbox::default();
        m.next_ray();
        let ids: Vec<u32> = (0..1000).map(|i| i * 7919 % 100_003).collect();
        assert!(ids.iter().all(|&id| m.first_visit(id | SHARED)));
        assert!(m.slots.len() >= 2000);
        assert!(ids.iter().all(|&id| !m.first_visit(id | SHARED)));
        m.next_ray();
        assert!(ids.iter().all(|&id| m.first_visit(id | SHARED)));
    }

    #[test]
    fn wrap_around_clears_the_slots() {
        let mut m = Mailbox::default();
        m.next_ray();
        m.ray = u32::MAX;
        assert!(m.first_visit(1 | SHARED));
        m.next_ray();
        assert_eq!(m.ray, 1);
        assert!(m.first_visit(1 | SHARED));
        assert!(!m.first_visit(1 | SHARED));
    }
}
