//! [`PlaneRows8`]: eight boxes by coordinate, as the 8-wide node stores its children's boxes
//! and its AVX2 box test loads them (`simd::slabs8`: one aligned 32-byte load a row).

use std::ops::{Deref, DerefMut};

/// Eight boxes by coordinate: rows min x, min y, min z, max x, max y, max z, lane `k` for box
/// `k`; each row 32 bytes on a 32-byte boundary.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct PlaneRows8(pub(crate) [[f32; 8]; 6]);

impl Deref for PlaneRows8 {
    type Target = [[f32; 8]; 6];

    #[inline(always)]
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl DerefMut for PlaneRows8 {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}
