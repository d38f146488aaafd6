//! Mailboxing: a triangle stored in several cells is tested at most once per ray.
//!
//! Each thread keeps one stamp per triangle, the number of the ray that last tested it (the
//! seed's "time stamping"). A new ray takes the next number, so nothing is cleared between
//! rays; on wrap-around (after 2^32 rays) the stamps are zeroed once. Ray numbers are drawn
//! from the one counter of the thread's mailbox, so the mailbox can be shared by every grid
//! the thread queries: a stamp left by another grid's ray is always an older number.
//!
//! Cells mark the references of triangles stored in one cell only ([`SHARED`] clear): those
//! cannot be met twice (each cell is visited once per ray), so they skip the stamp, which
//! saves a scattered memory access per test on meshes of small triangles.

/// Bit set in a cell's triangle reference when the triangle is stored in more than one cell.
pub(crate) const SHARED: u32 = 1 << 31;

/// Per-thread stamps (see the module docs): the `Accel::Scratch` of the grids.
#[derive(Debug, Default)]
pub struct Mailbox {
    stamps: Vec<u32>,
    ray: u32,
}

impl Mailbox {
    /// Starts a new ray over a structure of `triangles` triangles.
    #[inline]
    pub(crate) fn next_ray(&mut self, triangles: usize) {
        if self.stamps.len() < triangles {
            self.stamps.resize(triangles, 0);
        }
        self.ray = self.ray.wrapping_add(1);
        if self.ray == 0 {
            self.stamps.fill(0);
            self.ray = 1;
        }
    }

    /// True if the current ray meets the triangle of cell reference `reference` for the first
    /// time (always for a triangle stored in one cell only).
    #[inline(always)]
    pub(crate) fn first_visit(&mut self, reference: u32) -> bool {
        if reference & SHARED == 0 {
            return true;
        }
        let stamp = &mut self.stamps[(reference & !SHARED) as usize];
        let first = *stamp != self.ray;
        *stamp = self.ray;
        first
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_triangles_are_seen_once_per_ray() {
        let mut m = Mailbox::default();
        m.next_ray(4);
        assert!(m.first_visit(2 | SHARED));
        assert!(!m.first_visit(2 | SHARED));
        // Unshared references never touch the stamps.
        assert!(m.first_visit(3) && m.first_visit(3));
        m.next_ray(4);
        assert!(m.first_visit(2 | SHARED));
    }

    #[test]
    fn wrap_around_clears_the_stamps() {
        let mut m = Mailbox::default();
        m.next_ray(2);
        m.ray = u32::MAX;
        assert!(m.first_visit(1 | SHARED));
        m.next_ray(2);
        assert_eq!(m.ray, 1);
        assert!(m.first_visit(1 | SHARED));
        assert!(!m.first_visit(1 | SHARED));
    }
}
