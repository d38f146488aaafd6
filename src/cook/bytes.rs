//! The payload's encoding: little-endian words written one after the other, and a reader that
//! checks every length against the bytes it has before it allocates.

use glam::Vec3;

use super::CookError;

/// Writes a payload.
#[derive(Debug, Default)]
pub(crate) struct Writer {
    bytes: Vec<u8>,
}

impl Writer {
    /// The payload written so far.
    pub(crate) fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    pub(crate) fn u32(&mut self, value: u32) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub(crate) fn u64(&mut self, value: u64) {
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    pub(crate) fn f32(&mut self, value: f32) {
        self.u32(value.to_bits());
    }

    /// A count (of at most `u32::MAX`: every array the library keeps is numbered in `u32`).
    pub(crate) fn count(&mut self, count: usize) -> Result<(), CookError> {
        let count = u32::try_from(count).map_err(|_| CookError::TooLarge { count })?;
        self.u32(count);
        Ok(())
    }

    /// `values` after their count.
    pub(crate) fn u32s(&mut self, values: &[u32]) -> Result<(), CookError> {
        self.count(values.len())?;
        self.bytes.reserve(4 * values.len());
        values.iter().for_each(|&v| self.u32(v));
        Ok(())
    }

    /// `points` after their count, `x y z` each.
    pub(crate) fn points(&mut self, points: &[Vec3]) -> Result<(), CookError> {
        self.count(points.len())?;
        self.bytes.reserve(12 * points.len());
        points
            .iter()
            .flat_map(|p| p.to_array())
            .for_each(|c| self.f32(c));
        Ok(())
    }
}

/// Reads a payload; running past its end is [`CookError::Corrupt`] (the checksum held, so
/// the sizes inside disagree with each other).
#[derive(Debug)]
pub struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }

    /// The next `n` bytes.
    fn take(&mut self, n: usize) -> Result<&'a [u8], CookError> {
        if n > self.bytes.len() {
            return Err(CookError::Corrupt(
                "a size runs past the end of the payload",
            ));
        }
        let (taken, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(taken)
    }

    pub(crate) fn u32(&mut self) -> Result<u32, CookError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    pub(crate) fn u64(&mut self) -> Result<u64, CookError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    pub(crate) fn f32(&mut self) -> Result<f32, CookError> {
        Ok(f32::from_bits(self.u32()?))
    }

    /// A count, checked against the bytes left at `bytes_each` bytes an item, so that no
    /// allocation is larger than the file.
    pub(crate) fn count(&mut self, bytes_each: usize) -> Result<usize, CookError> {
        let count = self.u32()? as usize;
        if count.saturating_mul(bytes_each) > self.bytes.len() {
            return Err(CookError::Corrupt(
                "a count runs past the end of the payload",
            ));
        }
        Ok(count)
    }

    /// Words written by [`Writer::u32s`].
    pub(crate) fn u32s(&mut self) -> Result<Vec<u32>, CookError> {
        let count = self.count(4)?;
        self.words(count)
    }

    /// The next `count` words.
    pub(crate) fn words(&mut self, count: usize) -> Result<Vec<u32>, CookError> {
        let words = self.take(count.saturating_mul(4))?.chunks_exact(4);
        Ok(words
            .map(|w| u32::from_le_bytes(w.try_into().expect("4 bytes")))
            .collect())
    }

    /// Points written by [`Writer::points`].
    pub(crate) fn points(&mut self) -> Result<Vec<Vec3>, CookError> {
        let count = self.count(12)?;
        let coordinates = self.take(12 * count)?.chunks_exact(4);
        let values: Vec<f32> = coordinates
            .map(|w| f32::from_le_bytes(w.try_into().expect("4 bytes")))
            .collect();
        Ok(values.chunks_exact(3).map(Vec3::from_slice).collect())
    }

    /// Fails unless every byte was read.
    pub(crate) fn finish(self) -> Result<(), CookError> {
        if self.bytes.is_empty() {
            Ok(())
        } else {
            Err(CookError::Corrupt("bytes left after the last section"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_and_points_read_back() {
        let mut w = Writer::default();
        w.u32(7);
        w.u64(u64::MAX - 3);
        w.f32(-0.0);
        w.u32s(&[1, 2, 0xDEAD_BEEF]).unwrap();
        w.points(&[Vec3::new(1.0, -2.5, f32::MIN_POSITIVE)])
            .unwrap();
        let bytes = w.into_bytes();
        let mut r = Reader::new(&bytes);
        assert_eq!(r.u32().unwrap(), 7);
        assert_eq!(r.u64().unwrap(), u64::MAX - 3);
        assert_eq!(r.f32().unwrap().to_bits(), (-0.0f32).to_bits());
        assert_eq!(r.u32s().unwrap(), vec![1, 2, 0xDEAD_BEEF]);
        assert_eq!(
            r.points().unwrap(),
            vec![Vec3::new(1.0, -2.5, f32::MIN_POSITIVE)]
        );
        r.finish().unwrap();
    }

    #[test]
    fn a_count_past_the_end_is_refused_before_allocating() {
        let mut w = Writer::default();
        w.u32(u32::MAX);
        let bytes = w.into_bytes();
        assert!(matches!(
            Reader::new(&bytes).u32s(),
            Err(CookError::Corrupt(_))
        ));
        assert!(matches!(
            Reader::new(&bytes[..2]).u32(),
            Err(CookError::Corrupt(_))
        ));
    }
}
