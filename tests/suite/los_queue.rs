//! The line-of-sight queue: requests from several threads at once, answered by one flush,
//! equal the per-ray answers for every ticket; frames follow each other with the queue's
//! memory reused; a full queue, an unflushed or a stale ticket are typed errors.

use crate::common::meshes::icosphere;
use crate::common::rng::{in_cube, seeded};
use crate::common::scenes::build_scene;
use glam::Vec3;
use raybatch::scene::{InstanceDesc, Rigid};
use raybatch::users::{LosQueue, QueueError, Ticket};
use raybatch::{AccelKind, Mesh, Ray, RayQueries};

fn world() -> raybatch::Scene {
    let meshes: Vec<Mesh> = vec![icosphere(2)];
    let descs: Vec<InstanceDesc> = (0..9)
        .map(|i| {
            let at = Vec3::new((i % 3) as f32 * 3.0 - 3.0, (i / 3) as f32 * 3.0 - 3.0, 0.0);
            InstanceDesc::new(0, Rigid::from_translation(at).unwrap())
        })
        .collect();
    build_scene(&meshes, &[AccelKind::Bvh4], &descs)
}

#[test]
fn requests_from_many_threads_get_the_per_ray_answers() {
    let scene = world();
    let mut queue = LosQueue::with_capacity(4000).unwrap();
    for frame in 0..3u64 {
        let submitted: Vec<Vec<(Ticket, Vec3, Vec3)>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..4u64)
                .map(|t| {
                    let queue = &queue;
                    s.spawn(move || {
                        let mut rng = seeded(100 * frame + t);
                        (0..900)
                            .map(|_| {
                                let (a, b) = (in_cube(&mut rng, 6.0), in_cube(&mut rng, 6.0));
                                (queue.submit(a, b).unwrap(), a, b)
                            })
                            .collect()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(queue.len(), 3600);
        assert_eq!(queue.flush(&scene).unwrap(), 3600);
        let mut indices: Vec<usize> = submitted
            .iter()
            .flatten()
            .map(|(t, _, _)| t.index())
            .collect();
        indices.sort_unstable();
        assert_eq!(indices, (0..3600).collect::<Vec<_>>());
        let (mut clear, mut blocked) = (0, 0);
        for &(ticket, a, b) in submitted.iter().flatten() {
            let expected = !scene.occluded(&Ray::segment(a, b));
            assert_eq!(queue.visible(ticket), Ok(expected));
            if expected { clear += 1 } else { blocked += 1 }
        }
        assert!(
            clear > 100 && blocked > 100,
            "{clear} clear, {blocked} blocked"
        );
    }
}

#[test]
fn full_unflushed_and_stale_tickets_are_errors() {
    let scene = world();
    let mut queue = LosQueue::with_capacity(2).unwrap();
    let a = queue.submit(Vec3::ZERO, Vec3::X).unwrap();
    queue.submit(Vec3::ZERO, Vec3::Y).unwrap();
    assert_eq!(
        queue.submit(Vec3::ZERO, Vec3::Z),
        Err(QueueError::Full { capacity: 2 })
    );
    assert_eq!(queue.visible(a), Err(QueueError::NotFlushed));
    assert_eq!(queue.flush(&scene), Ok(2));
    assert!(queue.visible(a).is_ok());
    let b = queue
        .submit(Vec3::new(-9.0, 0.0, 0.0), Vec3::new(9.0, 0.0, 0.0))
        .unwrap();
    assert_eq!(queue.visible(b), Err(QueueError::NotFlushed));
    assert_eq!(queue.flush(&scene), Ok(1));
    assert_eq!(queue.visible(a), Err(QueueError::Stale));
    assert_eq!(queue.visible(b), Ok(false));
    // An empty frame flushes to nothing; an invalid segment is clear.
    assert_eq!(queue.flush(&scene), Ok(0));
    let c = queue.submit(Vec3::ONE, Vec3::ONE).unwrap();
    queue.flush(&scene).unwrap();
    assert_eq!(queue.visible(c), Ok(true));
}

#[test]
fn lists_submitted_at_once_get_consecutive_tickets() {
    let scene = world();
    let mut queue = LosQueue::with_capacity(10).unwrap();
    let rays: Vec<Ray> = (0..4)
        .map(|i| {
            Ray::segment(
                Vec3::new(-9.0, i as f32 * 3.0 - 4.5, 0.0),
                Vec3::new(9.0, i as f32 * 3.0 - 4.5, 0.0),
            )
        })
        .collect();
    let single = queue
        .submit(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, 9.0))
        .unwrap();
    let first = queue.submit_all(&rays).unwrap();
    assert_eq!(first.index(), 1);
    // Too many for the room left: refused whole, nothing taken.
    assert_eq!(
        queue.submit_all(&[rays[0]; 6]),
        Err(QueueError::Full { capacity: 10 })
    );
    assert_eq!(queue.len(), 5);
    assert_eq!(queue.flush(&scene), Ok(5));
    assert_eq!(queue.visible(single), Ok(true));
    for (k, ray) in rays.iter().enumerate() {
        assert_eq!(queue.visible(first.offset(k)), Ok(!scene.occluded(ray)));
    }
    // Past the list: not the answer of the request taken after it, but no answer at all.
    let after = queue.submit_all(&rays).unwrap();
    queue.submit(Vec3::ZERO, Vec3::X).unwrap();
    queue.flush(&scene).unwrap();
    for k in [4, 5, usize::MAX] {
        assert_eq!(
            queue.visible(after.offset(k)),
            Err(QueueError::UnknownTicket)
        );
    }
    assert_eq!(
        queue.visible(after.offset(1).offset(1)),
        Err(QueueError::UnknownTicket)
    );
}

/// Tickets only open answers of the queue that issued them: another queue's ticket, or an
/// offset past the list a ticket was taken for, is refused with a typed error, never a panic;
/// capacities outside 1..=MAX_CAPACITY are refused at construction.
#[test]
fn foreign_tickets_and_bad_capacities_are_errors() {
    let scene = world();
    let mut small = LosQueue::with_capacity(2).unwrap();
    let mut large = LosQueue::with_capacity(100).unwrap();
    let segment = (Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, 9.0));
    let mine = small.submit(segment.0, segment.1).unwrap();
    let mut foreign = large.submit(segment.0, segment.1).unwrap();
    for _ in 0..50 {
        foreign = large.submit(segment.0, segment.1).unwrap();
    }
    assert_eq!(small.flush(&scene), Ok(1));
    assert_eq!(large.flush(&scene), Ok(51));
    assert_eq!(small.visible(mine), Ok(true));
    assert_eq!(small.visible(foreign), Err(QueueError::UnknownTicket));
    assert_eq!(large.visible(mine), Err(QueueError::UnknownTicket));
    assert_eq!(
        small.visible(mine.offset(7)),
        Err(QueueError::UnknownTicket)
    );
    assert_eq!(
        small.visible(mine.offset(usize::MAX)),
        Err(QueueError::UnknownTicket)
    );
    for capacity in [0, LosQueue::MAX_CAPACITY + 1, usize::MAX] {
        assert_eq!(
            LosQueue::with_capacity(capacity).err(),
            Some(QueueError::BadCapacity {
                requested: capacity
            })
        );
    }
}
