use super::*;
use glam::{DVec2, DVec3};
use rand::SeedableRng;

/// Two fills of `count` particles each (radius 0.5, then 1) placed at random in the box
/// (-half, half)^D, `batch` tries at a time, across periodic seams when `periodic`.
fn placed<V: Vector>(batch: usize, count: u64, half: f64, periodic: bool) -> Particles<V> {
    let ctx = Ctx {
        origin: "test",
        progress: &|_, _| {},
    };
    let region = Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap();
    let seams = periodic.then(|| {
        (
            Periodic::new(&region, &[true; 3][..V::DIM]).unwrap(),
            region,
        )
    });
    let mut placer = Placer {
        grid: PlacementGrid::new(region, 1.0, 2 * count as usize),
        seams,
        total: 2 * count,
    };
    let mut out = Particles::new();
    for (i, radius) in [(0, 0.5), (1, 1.0)] {
        let fill = Fill {
            count,
            radius,
            mass: 1.0,
            speed: 2.0,
            base_velocity: V::ZERO,
            region,
        };
        let mut rng = Pcg64::seed_from_u64(11 + i as u64);
        place_random(&ctx, i, &fill, &mut rng, &mut placer, &mut out, |_| batch).unwrap();
    }
    out
}

/// A small fill draws the tries it needs, not a big fill's batch (a fuzzed scene of 100
/// discs checked 30,000 survivors against each other in a few cells); a big one, and one
/// whose last batch placed nothing, draw full batches.
#[test]
fn batches_fit_what_is_left() {
    let so_far = |placed, left, last| SoFar { placed, left, last };
    assert_eq!(batch_size(so_far(0, 100, None)), 400);
    assert_eq!(batch_size(so_far(50, 50, Some((400, 50)))), 800);
    assert_eq!(batch_size(so_far(0, 10, None)), MIN_TRIES_PER_BATCH);
    assert_eq!(batch_size(so_far(0, 1 << 20, None)), TRIES_PER_BATCH);
    assert_eq!(
        batch_size(so_far(1 << 22, 9, Some((9, 0)))),
        MAX_TRIES_PER_BATCH
    );
}

/// The smallest and the largest distance from a particle to its nearest neighbour, by
/// brute force.
fn nearest_range<V: Vector>(p: &Particles<V>) -> (f64, f64) {
    let x = p.positions();
    let nearest = |i: usize| {
        (0..x.len())
            .filter(|&j| j != i)
            .map(|j| (x[i] - x[j]).length_squared().sqrt())
            .fold(f64::INFINITY, f64::min)
    };
    (0..x.len())
        .map(nearest)
        .fold((f64::INFINITY, 0.0), |(lo, hi), d| (lo.min(d), hi.max(d)))
}

/// `arrangement = "hex"`: a close packing, every particle's nearest neighbour a hair more
/// than a diameter away, as many as fit (2D: 11 rows of 10 and 9 discs in a box a hair over
/// 10 diameters square; 3D: hexagonal close packing, 74 % of space less the edges).
#[test]
fn hex_fills_a_close_packing() {
    let scene = |dim: u32, count: u64, max: f64| {
        let corner = |v: f64| vec![v; dim as usize];
        let text = format!(
            "dimensions = {dim}\ndt = 0.01\n[domain]\nmin = {:?}\nmax = {:?}\n\
             [[fill]]\ncount = {count}\nradius = 0.5\narrangement = \"hex\"\n",
            corner(0.0),
            corner(max)
        );
        crate::parse(&text, "test")
    };
    // 2D: 11 rows sqrt(3)/2 apart fit in 10, 6 of 10 discs and 5 of 9
    let two = match scene(2, 105, 10.00001).unwrap() {
        crate::AnyScene::Two(s) => s.particles,
        _ => unreachable!(),
    };
    let (lo, hi) = nearest_range(&two);
    assert!(
        (1.0..1.0 + 1e-6).contains(&lo) && hi < 1.0 + 1e-6,
        "{lo} {hi}"
    );
    let top = two.positions().iter().map(|x| x.y).fold(0.0, f64::max);
    assert!((top - (0.5 + 10.0 * 0.75f64.sqrt())).abs() < 1e-6, "{top}");
    assert!(scene(2, 106, 10.00001).is_err());
    // 3D: layers sqrt(2/3) apart, the odd ones over the hollows of the even ones
    let three = match scene(3, 1500, 12.0).unwrap() {
        crate::AnyScene::Three(s) => s.particles,
        _ => unreachable!(),
    };
    let (lo, hi) = nearest_range(&three);
    assert!(
        (1.0..1.0 + 1e-6).contains(&lo) && hi < 1.0 + 1e-6,
        "{lo} {hi}"
    );
}

/// Progress comes after each batch, never falls back, and ends at the total.
#[test]
fn progress_rises_to_the_total() {
    // (the random fill at 39 % of the area: more than one batch of tries)
    let text =
        "dimensions = 2\ndt = 0.01\n[domain]\nmin = [-100.0, -100.0]\nmax = [100.0, 100.0]\n\
                [[fill]]\ncount = 20000\nradius = 0.5\nseed = 3\n\
                [[fill]]\ncount = 100\nradius = 0.1\narrangement = \"lattice\"\n";
    let reports = std::cell::RefCell::new(Vec::new());
    crate::parse_with_progress(text, "test", &|placed, total| {
        reports.borrow_mut().push((placed, total))
    })
    .unwrap();
    let reports = reports.into_inner();
    assert!(reports.len() >= 2, "{reports:?}");
    assert!(reports.windows(2).all(|w| w[0].0 <= w[1].0), "{reports:?}");
    assert!(reports.iter().all(|&(_, total)| total == 20100));
    assert_eq!(reports.last(), Some(&(20100, 20100)));
}

/// The particles placed are those of one try after another (a batch of one), whatever the
/// batch: the batches only change how the tries are checked.
#[test]
fn batches_place_the_same_particles_as_one_try_at_a_time() {
    fn same<V: Vector>(count: u64, half: f64, periodic: bool) {
        let one = placed::<V>(1, count, half, periodic);
        assert_eq!(one.len(), 2 * count as usize);
        let (x, r) = (one.positions(), one.radii());
        let box_ = Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap();
        let seams = Periodic::new(&box_, &[periodic; 3][..V::DIM]);
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                let xj = seams.map_or(x[j], |p| p.image(x[i], x[j]));
                let reach = r[i] + r[j];
                assert!(
                    (x[i] - xj).length_squared() >= reach * reach,
                    "{i} and {j} overlap"
                );
            }
        }
        for batch in [2, 7, 64, TRIES_PER_BATCH] {
            let got = placed::<V>(batch, count, half, periodic);
            assert_eq!(
                got.positions(),
                one.positions(),
                "{}D, batch {batch}",
                V::DIM
            );
            assert_eq!(
                got.velocities(),
                one.velocities(),
                "{}D, batch {batch}",
                V::DIM
            );
            assert_eq!(got.radii(), one.radii(), "{}D, batch {batch}", V::DIM);
        }
    }
    // (dense enough that most late tries are refused, and many by a try of the same batch)
    same::<DVec2>(150, 20.0, false);
    same::<DVec2>(150, 20.0, true);
    same::<DVec3>(150, 8.0, false);
    same::<DVec3>(150, 8.0, true);
}
