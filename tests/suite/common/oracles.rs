//! The references the structures are checked against: the brute-force answers compared bit
//! for bit (closest hit, occlusion, every hit, both kernels), the tie rule, and the checks that
//! every structure agrees (or misses) on a ray.

use raybatch::brute_force;
use raybatch::{Hit, Kernel, Mesh, Ray};

use super::zoo::Built;

/// A hit as exact bits: (triangle, t, u, v).
pub type HitBits = (u32, u32, u32, u32);

pub fn bits(h: &Hit) -> HitBits {
    (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits())
}

pub fn opt_bits(h: Option<Hit>) -> Option<HitBits> {
    h.as_ref().map(bits)
}

pub fn all_bits(hits: &[Hit]) -> Vec<HitBits> {
    hits.iter().map(bits).collect()
}

/// Brute-force answers for one ray, computed once and compared with every structure.
pub struct Reference {
    pub ray: Ray,
    /// Per kernel (in [`Kernel::ALL`] order): closest hit, occluded, all hits sorted.
    pub answers: Vec<(Kernel, Option<Hit>, bool, Vec<Hit>)>,
}

impl Reference {
    pub fn new(mesh: &Mesh, ray: &Ray) -> Self {
        let answers = Kernel::ALL
            .iter()
            .map(|&k| {
                (
                    k,
                    brute_force::cast_ray(mesh, ray, k),
                    brute_force::occluded(mesh, ray, k),
                    brute_force::all_hits(mesh, ray, k),
                )
            })
            .collect();
        Self { ray: *ray, answers }
    }
}

/// Compares every query of one structure with the brute-force reference on one ray, bit for bit:
/// closest hit (id, `t`, `u`, `v`), occlusion and every hit, for both kernels, plus the
/// default-kernel methods. Returns a description of the first difference.
pub fn compare_structure(t: &Built, reference: &Reference) -> Result<(), String> {
    let name = &t.name;
    let ray = &reference.ray;
    for (kernel, expected, expected_occ, expected_all) in &reference.answers {
        let (kernel, expected, expected_occ) = (*kernel, *expected, *expected_occ);
        let got = t.accel.cast_ray_with(ray, kernel);
        let got_occ = t.accel.occluded_with(ray, kernel);
        if opt_bits(got) != opt_bits(expected) || got_occ != expected_occ {
            return Err(format!(
                "{name} {kernel:?}: cast_ray {got:?} / occluded {got_occ}, brute force \
                 {expected:?} / occluded {expected_occ}, for {ray:?}"
            ));
        }
        // Every hit from the callback, as a multiset (compared in a canonical order).
        let mut each = all_bits(&t.each_hit_with(ray, kernel));
        each.sort_unstable();
        let mut sorted_expected = all_bits(expected_all);
        sorted_expected.sort_unstable();
        if each != sorted_expected {
            return Err(format!(
                "{name} {kernel:?} for_each_hit: got {each:?}, brute force {expected_all:?} \
                 for {ray:?}"
            ));
        }
    }
    let (_, wt, wt_occ, wt_all) = &reference.answers[0];
    if opt_bits(t.accel.cast_ray(ray)) != opt_bits(*wt) {
        return Err(format!(
            "{name}: cast_ray differs from cast_ray_with(Watertight)"
        ));
    }
    if t.accel.occluded(ray) != *wt_occ {
        return Err(format!(
            "{name}: occluded differs from occluded_with(Watertight)"
        ));
    }
    let got_all = all_bits(&t.accel.all_hits(ray));
    if got_all != all_bits(wt_all) {
        return Err(format!(
            "{name} all_hits: got {got_all:?}, brute force {wt_all:?} for {ray:?}"
        ));
    }
    let mut each = all_bits(&t.each_hit(ray));
    each.sort_unstable();
    let mut sorted = got_all.clone();
    sorted.sort_unstable();
    if each != sorted {
        return Err(format!(
            "{name}: for_each_hit differs from all_hits for {ray:?}"
        ));
    }
    Ok(())
}

/// [`compare_structure`] for every structure (brute force evaluated once).
pub fn compare_all(mesh: &Mesh, zoo: &[Built], ray: &Ray) -> Result<(), String> {
    assert_eq!(Kernel::ALL[0], Kernel::Watertight);
    let reference = Reference::new(mesh, ray);
    zoo.iter()
        .try_for_each(|t| compare_structure(t, &reference))
}

/// [`compare_all`], panicking with the difference.
#[track_caller]
pub fn assert_matches_brute_force(mesh: &Mesh, zoo: &[Built], ray: &Ray) {
    if let Err(e) = compare_all(mesh, zoo, ray) {
        panic!("{e}\nmesh: {}", describe(mesh));
    }
}

/// The tie rule on the brute-force reference: the closest hit is the first of `all_hits`,
/// bit for bit (which requires `all_hits` to order equal `t` by id).
pub fn closest_is_first_of_all_hits(mesh: &Mesh, ray: &Ray) -> Result<(), String> {
    for kernel in Kernel::ALL {
        let all = brute_force::all_hits(mesh, ray, kernel);
        let closest = brute_force::cast_ray(mesh, ray, kernel);
        if opt_bits(all.first().copied()) != opt_bits(closest) {
            return Err(format!(
                "{kernel:?}: cast_ray {closest:?} is not all_hits()[0] in {all:?} for {ray:?}"
            ));
        }
    }
    Ok(())
}

/// A compact description of a mesh: `id: [a, b, c]` for every non-degenerate triangle.
pub fn describe(mesh: &Mesh) -> String {
    (0..mesh.triangle_count() as u32)
        .filter(|&id| !mesh.is_degenerate(id))
        .map(|id| format!("{id}: {:?}", mesh.triangle(id).map(|p| p.to_array())))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The triangles hit at the smallest `t` (brute force, watertight), lowest id first.
pub fn closest_ids(mesh: &Mesh, ray: &Ray) -> Vec<u32> {
    let hits = brute_force::all_hits(mesh, ray, Kernel::Watertight);
    match hits.first() {
        None => vec![],
        Some(first) => hits
            .iter()
            .filter(|h| h.t == first.t)
            .map(|h| h.triangle)
            .collect(),
    }
}

/// Every structure's watertight closest hit, checked to be the same bits for all of them.
#[track_caller]
pub fn unanimous_hit(zoo: &[Built], ray: &Ray) -> Option<Hit> {
    let first = zoo[0].accel.cast_ray_with(ray, Kernel::Watertight);
    for t in zoo {
        let h = t.accel.cast_ray_with(ray, Kernel::Watertight);
        assert_eq!(
            opt_bits(h),
            opt_bits(first),
            "{} disagrees on {ray:?}",
            t.name
        );
    }
    first
}

/// Brute force and every query of every structure miss `ray`, with both kernels, and count
/// it as occluded only if it is invalid (line of sight fails closed).
#[track_caller]
pub fn assert_misses_everywhere(mesh: &Mesh, zoo: &[Built], ray: &Ray) {
    let invalid = !ray.is_valid();
    for kernel in Kernel::ALL {
        assert_eq!(brute_force::cast_ray(mesh, ray, kernel), None, "{ray:?}");
        assert_eq!(brute_force::occluded(mesh, ray, kernel), invalid);
    }
    assert!(brute_force::all_hits(mesh, ray, Kernel::Watertight).is_empty());
    for t in zoo {
        for kernel in Kernel::ALL {
            assert_eq!(
                t.accel.cast_ray_with(ray, kernel),
                None,
                "{} {kernel:?} {ray:?}",
                t.name
            );
            assert_eq!(
                t.accel.occluded_with(ray, kernel),
                invalid,
                "{} {kernel:?} {ray:?}",
                t.name
            );
        }
        assert_eq!(t.accel.cast_ray(ray), None);
        assert_eq!(t.accel.occluded(ray), invalid);
        assert!(t.accel.all_hits(ray).is_empty(), "{} {ray:?}", t.name);
        assert!(t.each_hit(ray).is_empty(), "{} {ray:?}", t.name);
    }
}
