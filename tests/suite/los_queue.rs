//! The line-of-sight queue: requests from several threads at once, answered by one flush,
//! equal the per-ray answers for every ticket; frames follow each other with the queue's
//! memory reused; a full queue, an unflushed or a stale ticket are typed errors.

use crate::common::meshes::icosphere;
use crate::common::rng::{in_cube, seeded};
use crate::common::scenes::build_scene;
use glam::Vec3;
use raybatch::scene::{InstanceDesc, Rigid};
use raybatch::users::{LosQueue, QueueError, Ticket};
use raybatch::{AccelKind, Mesh, Ray, RayError, RayQueries};

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
    let queue = LosQueue::with_capacity(4000).unwrap();
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
        assert_eq!(queue.flush(&scene), Ok(3600));
        let mut indices: Vec<usize> = submitted
            .iter()
            .flatten()
            .map(|(t, _, _)| t.index())
            .collect();
        indices.sort_unstable();
        assert_eq!(indices, (0..3600).collect::<Vec<_>>());
        let (mut clear, mut blocked) = (0, 0);
        for &(ticket, a, b) in submitted.iter().flatten() {
            let expected = scene.occluded(&Ray::segment(a, b));
            assert_eq!(queue.occluded(ticket), Ok(expected));
            if expected { blocked += 1 } else { clear += 1 }
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
    let queue = LosQueue::with_capacity(2).unwrap();
    let a = queue.submit(Vec3::ZERO, Vec3::X).unwrap();
    queue.submit(Vec3::ZERO, Vec3::Y).unwrap();
    assert_eq!(
        queue.submit(Vec3::ZERO, Vec3::Z),
        Err(QueueError::Full { capacity: 2 })
    );
    assert_eq!(queue.occluded(a), Err(QueueError::NotFlushed));
    assert_eq!(queue.flush(&scene), Ok(2));
    assert!(queue.occluded(a).is_ok());
    let b = queue
        .submit(Vec3::new(-9.0, 0.0, 0.0), Vec3::new(9.0, 0.0, 0.0))
        .unwrap();
    assert_eq!(queue.occluded(b), Err(QueueError::NotFlushed));
    assert_eq!(queue.flush(&scene), Ok(1));
    assert_eq!(queue.occluded(a), Err(QueueError::Stale));
    assert_eq!(queue.occluded(b), Ok(true));
    // An empty frame flushes to nothing.
    assert_eq!(queue.flush(&scene), Ok(0));
}

/// A sightline that cannot be traced is refused at submit, never answered "clear"; a list
/// holding one is refused whole.
#[test]
fn invalid_sightlines_are_refused() {
    let queue = LosQueue::with_capacity(8).unwrap();
    let nan = Vec3::new(f32::NAN, 1.0, 0.0);
    let cases = [
        (nan, Vec3::X, RayError::NonFiniteOrigin),
        (Vec3::ZERO, nan, RayError::NonFiniteDirection),
        (
            Vec3::ZERO,
            Vec3::new(0.0, f32::INFINITY, 0.0),
            RayError::NonFiniteDirection,
        ),
        (Vec3::ONE, Vec3::ONE, RayError::ZeroDirection),
    ];
    for (from, to, error) in cases {
        assert_eq!(
            queue.submit(from, to),
            Err(QueueError::InvalidRay { index: 0, error })
        );
    }
    let mut rays = vec![Ray::segment(Vec3::ZERO, Vec3::X); 4];
    rays[2] = Ray::segment(nan, Vec3::X);
    assert_eq!(
        queue.submit_all(&rays),
        Err(QueueError::InvalidRay {
            index: 2,
            error: RayError::NonFiniteOrigin
        })
    );
    assert!(queue.is_empty());
    // An empty list takes nothing; a list longer than the capacity never fits.
    let none = queue.submit_all(&[]).unwrap();
    assert_eq!(queue.occluded(none), Err(QueueError::UnknownTicket));
    assert_eq!(
        queue.submit_all(&[Ray::segment(Vec3::ZERO, Vec3::X); 9]),
        Err(QueueError::Full { capacity: 8 })
    );
    assert!(queue.is_empty());
}

/// Flushes called from several threads at once: one runs, the others return `FlushRunning`
/// having closed nothing, and every request is answered by exactly one flush.
#[test]
fn flushes_called_at_once_answer_each_request_once() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let scene = world();
    let queue = LosQueue::with_capacity(1000).unwrap();
    let answered = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for t in 0..3u64 {
            let (queue, scene, answered) = (&queue, &scene, &answered);
            s.spawn(move || {
                let mut rng = seeded(900 + t);
                for _ in 0..200 {
                    let (a, b) = (in_cube(&mut rng, 6.0), in_cube(&mut rng, 6.0));
                    queue.submit(a, b).unwrap();
                    match queue.flush(scene) {
                        Ok(n) => _ = answered.fetch_add(n, Ordering::Relaxed),
                        Err(e) => assert_eq!(e, QueueError::FlushRunning),
                    }
                }
            });
        }
    });
    let rest = queue.flush(&scene).unwrap();
    assert_eq!(answered.load(Ordering::Relaxed) + rest, 600);
}

#[test]
fn lists_submitted_at_once_get_consecutive_tickets() {
    let scene = world();
    let queue = LosQueue::with_capacity(10).unwrap();
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
    assert_eq!(queue.occluded(single), Ok(false));
    for (k, ray) in rays.iter().enumerate() {
        assert_eq!(queue.occluded(first.offset(k)), Ok(scene.occluded(ray)));
    }
    // Past the list: not the answer of the request taken after it, but no answer at all.
    let after = queue.submit_all(&rays).unwrap();
    queue.submit(Vec3::ZERO, Vec3::X).unwrap();
    queue.flush(&scene).unwrap();
    for k in [4, 5, usize::MAX] {
        assert_eq!(
            queue.occluded(after.offset(k)),
            Err(QueueError::UnknownTicket)
        );
    }
    assert_eq!(
        queue.occluded(after.offset(1).offset(1)),
        Err(QueueError::UnknownTicket)
    );
}

/// Tickets only open answers of the queue that issued them: another queue's ticket, or an
/// offset past the list a ticket was taken for, is refused with a typed error, never a panic;
/// capacities outside 1..=MAX_CAPACITY are refused at construction.
#[test]
fn foreign_tickets_and_bad_capacities_are_errors() {
    let scene = world();
    let small = LosQueue::with_capacity(2).unwrap();
    let large = LosQueue::with_capacity(100).unwrap();
    let segment = (Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, 9.0));
    let mine = small.submit(segment.0, segment.1).unwrap();
    let mut foreign = large.submit(segment.0, segment.1).unwrap();
    for _ in 0..50 {
        foreign = large.submit(segment.0, segment.1).unwrap();
    }
    assert_eq!(small.flush(&scene), Ok(1));
    assert_eq!(large.flush(&scene), Ok(51));
    assert_eq!(small.occluded(mine), Ok(false));
    assert_eq!(small.occluded(foreign), Err(QueueError::UnknownTicket));
    assert_eq!(large.occluded(mine), Err(QueueError::UnknownTicket));
    assert_eq!(
        small.occluded(mine.offset(7)),
        Err(QueueError::UnknownTicket)
    );
    assert_eq!(
        small.occluded(mine.offset(usize::MAX)),
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

/// A job system's use: producers submit from several threads while another thread flushes
/// frame after frame. Every request is answered exactly once (the flushes' counts add up to
/// the requests taken, and no frame hands out an index twice), and every answer read equals
/// the per-ray answer of the request's own segment.
#[test]
fn concurrent_submits_and_flushes_lose_and_mix_nothing() {
    use std::collections::HashSet;
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

    let scene = world();
    // Room for every producer's unread requests (at most 5 each): no submit is refused.
    let queue = LosQueue::with_capacity(64).unwrap();
    let (producers, rounds) = (4u64, 2000);
    let submitted = AtomicUsize::new(0);
    let read = AtomicUsize::new(0);
    let producing = AtomicUsize::new(producers as usize);
    let done = AtomicBool::new(false);
    let taken: Mutex<HashSet<(u64, usize)>> = Mutex::new(HashSet::new());
    let flushed = std::thread::scope(|s| {
        let flusher = s.spawn(|| {
            let mut flushed = 0;
            loop {
                let finished = producing.load(Ordering::Acquire) == 0;
                flushed += queue.flush(&scene).unwrap();
                // Answers live until the next frame is answered: let every answer of this
                // frame be read first (requests of the next frame keep coming meanwhile).
                while read.load(Ordering::Acquire) < flushed {
                    std::thread::yield_now();
                }
                if finished {
                    done.store(true, Ordering::Release);
                    return flushed;
                }
            }
        });
        for p in 0..producers {
            let (queue, scene, taken) = (&queue, &scene, &taken);
            let (submitted, read, producing) = (&submitted, &read, &producing);
            s.spawn(move || {
                let mut rng = seeded(7000 + p);
                for round in 0..rounds {
                    let rays: Vec<Ray> = (0..1 + round % 5)
                        .map(|_| Ray::segment(in_cube(&mut rng, 6.0), in_cube(&mut rng, 6.0)))
                        .collect();
                    let tickets: Vec<Ticket> = if round % 2 == 0 {
                        let first = queue.submit_all(&rays).unwrap();
                        (0..rays.len()).map(|k| first.offset(k)).collect()
                    } else {
                        rays.iter()
                            .map(|&ray| queue.submit_ray(ray).unwrap())
                            .collect()
                    };
                    submitted.fetch_add(rays.len(), Ordering::AcqRel);
                    for (ticket, ray) in tickets.iter().zip(&rays) {
                        assert!(
                            taken
                                .lock()
                                .unwrap()
                                .insert((ticket.frame(), ticket.index()))
                        );
                        let answer = loop {
                            match queue.occluded(*ticket) {
                                Err(QueueError::NotFlushed) => std::thread::yield_now(),
                                other => break other,
                            }
                        };
                        assert_eq!(answer, Ok(scene.occluded(ray)), "{ticket:?}");
                        read.fetch_add(1, Ordering::AcqRel);
                    }
                }
                producing.fetch_sub(1, Ordering::AcqRel);
            });
        }
        flusher.join().unwrap()
    });
    assert!(done.load(Ordering::Acquire));
    let expected: usize = (0..rounds).map(|r| 1 + r % 5).sum::<usize>() * producers as usize;
    assert_eq!(submitted.load(Ordering::Acquire), expected);
    assert_eq!(flushed, expected);
    assert_eq!(taken.lock().unwrap().len(), expected);
}

/// A job system's frame, a thousand times: eight producer threads submit (one by one, as
/// lists, with and without filters), one flush per frame answers them, and every producer
/// reads every answer and compares it with the per-ray answer through the same filter.
#[test]
#[ignore = "heavy: 8 producers x 1,000 frames (the full tier)"]
fn eight_producers_a_thousand_frames() {
    use std::sync::Barrier;
    use std::sync::atomic::{AtomicUsize, Ordering};

    use raybatch::scene::RayFilter;

    let scene = world();
    let (producers, frames, per_frame) = (8usize, 1000usize, 24usize);
    let queue = LosQueue::with_capacity(producers * per_frame).unwrap();
    let submitted = Barrier::new(producers + 1);
    let answered = Barrier::new(producers + 1);
    let checked = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for p in 0..producers {
            let (queue, scene, checked) = (&queue, &scene, &checked);
            let (submitted, answered) = (&submitted, &answered);
            s.spawn(move || {
                let mut rng = seeded(9000 + p as u64);
                for frame in 0..frames {
                    let rays: Vec<Ray> = (0..per_frame)
                        .map(|_| Ray::segment(in_cube(&mut rng, 6.0), in_cube(&mut rng, 6.0)))
                        .collect();
                    let filters: Vec<RayFilter> = (0..per_frame)
                        .map(|k| match (frame + k + p) % 4 {
                            0 => RayFilter::ALL,
                            1 => RayFilter::ALL.ignoring(((k + p) % 9) as u32),
                            2 => RayFilter::ALL.culling_back_faces(),
                            _ => RayFilter::ALL.without_ends().ignoring((k % 9) as u32),
                        })
                        .collect();
                    let tickets: Vec<Ticket> = if (frame + p) % 2 == 0 {
                        let first = queue.submit_all_filtered(&rays, &filters).unwrap();
                        (0..per_frame).map(|k| first.offset(k)).collect()
                    } else {
                        rays.iter()
                            .zip(&filters)
                            .map(|(r, f)| queue.submit_filtered(*r, *f).unwrap())
                            .collect()
                    };
                    submitted.wait();
                    answered.wait();
                    for ((ray, filter), ticket) in rays.iter().zip(&filters).zip(tickets) {
                        let expected = scene.filtered(*filter).occluded(ray);
                        assert_eq!(queue.occluded(ticket), Ok(expected), "frame {frame}");
                        checked.fetch_add(1, Ordering::Relaxed);
                    }
                }
            });
        }
        for _ in 0..frames {
            submitted.wait();
            assert_eq!(queue.flush(&scene), Ok(producers * per_frame));
            answered.wait();
        }
    });
    assert_eq!(
        checked.load(Ordering::Relaxed),
        producers * frames * per_frame
    );
}
