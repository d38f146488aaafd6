//! Hit-by-hit agreement of a peer with the reference (raybatch's single-ray `cast_ray`).

use crate::engines::PeerHit;

/// Relative tolerance on `t`: `|t_peer - t_ref| <= T_TOLERANCE * max(1, t_ref)`.
pub const T_TOLERANCE: f32 = 1e-4;

/// Disagreement counts over one ray set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Agreement {
    /// Rays the peer hits.
    pub hits: usize,
    /// The reference hits and the peer misses.
    pub peer_misses: usize,
    /// The peer hits and the reference misses.
    pub peer_extra_hits: usize,
    /// Both hit, at `t` values further apart than the tolerance.
    pub t_differs: usize,
    /// Both hit at the same `t` (within tolerance) but report different triangles: a tie on a
    /// shared edge or vertex, which each library breaks its own way.
    pub triangle_differs: usize,
}

impl Agreement {
    pub fn hit_miss(&self) -> usize {
        self.peer_misses + self.peer_extra_hits
    }
}

/// True if `t` agrees with `reference` within [`T_TOLERANCE`].
pub fn same_t(t: f32, reference: f32) -> bool {
    (t - reference).abs() <= T_TOLERANCE * reference.abs().max(1.0)
}

/// Counts disagreements; the slices are per ray, in the same order. `examples` receives the
/// first few disagreeing ray indices (at most `examples_max`).
pub fn compare(
    reference: &[Option<PeerHit>],
    peer: &[Option<PeerHit>],
    examples: &mut Vec<usize>,
    examples_max: usize,
) -> Agreement {
    assert_eq!(reference.len(), peer.len(), "both ran the same rays");
    let mut a = Agreement::default();
    for (i, (r, p)) in reference.iter().zip(peer).enumerate() {
        a.hits += p.is_some() as usize;
        let disagrees = match (r, p) {
            (None, None) => false,
            (Some(_), None) => {
                a.peer_misses += 1;
                true
            }
            (None, Some(_)) => {
                a.peer_extra_hits += 1;
                true
            }
            (Some(r), Some(p)) => {
                if !same_t(p.t, r.t) {
                    a.t_differs += 1;
                    true
                } else if p.triangle != r.triangle {
                    a.triangle_differs += 1;
                    false
                } else {
                    false
                }
            }
        };
        if disagrees && examples.len() < examples_max {
            examples.push(i);
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(t: f32, triangle: u32) -> Option<PeerHit> {
        Some(PeerHit { t, triangle })
    }

    #[test]
    fn counts_each_kind_of_disagreement() {
        let reference = [h(1.0, 0), None, h(2.0, 1), h(100.0, 2), h(3.0, 3), None];
        let peer = [h(1.0, 0), h(5.0, 9), None, h(100.005, 2), h(3.0, 4), None];
        let mut ex = Vec::new();
        let a = compare(&reference, &peer, &mut ex, 10);
        assert_eq!(
            a,
            Agreement {
                hits: 4,
                peer_misses: 1,
                peer_extra_hits: 1,
                t_differs: 0,
                triangle_differs: 1,
            }
        );
        assert_eq!(ex, [1, 2]);
        // Absolute tolerance below t = 1, relative above.
        assert!(same_t(0.50009, 0.5) && !same_t(0.5002, 0.5));
        assert!(same_t(1000.09, 1000.0) && !same_t(1000.2, 1000.0));
        let a = compare(&[h(1.0, 0)], &[h(1.01, 0)], &mut ex, 10);
        assert_eq!(a.t_differs, 1);
    }
}
