use super::*;
use crate::domain::Aabb;
use crate::response::is_overlapping;
use glam::{DVec2, DVec3};

/// A layout over `bounds` with `cells` per axis (all axes the same).
fn layout<V: Vector>(bounds: Aabb<V>, cells: usize) -> GridLayout {
    GridLayout::fit(&bounds, 1.0, Some([cells; 3]), f64::INFINITY)
}

/// The copy of `positions` and `radii` in their own order on `layout`, or `None` when it
/// cannot be taken.
fn packed<V: Vector>(
    positions: &[V],
    radii: &[f64],
    layout: &GridLayout,
) -> Option<(Packed, PlanarUnits)> {
    let ids: Vec<u32> = (0..positions.len() as u32).collect();
    let largest = radii.iter().copied().fold(0.0, f64::max);
    let (mut packed, mut planar) = (Packed::default(), PlanarUnits::new());
    let taken = packed.fill(
        (positions, radii, largest),
        &ids,
        layout,
        &mut planar,
        false,
    );
    taken.then_some((packed, planar))
}

/// The places `1..n` whose particles the prefilter passes against place 0's.
fn passed<V: Vector>(positions: &[V], radii: &[f64], layout: &GridLayout) -> Option<Vec<usize>> {
    let (packed, planar) = packed(positions, radii, layout)?;
    let mut found = Vec::new();
    let probe = packed.probe::<V>(&planar, 0);
    packed.scan::<V>(&planar, probe, (1, positions.len()), &mut |k| found.push(k));
    Some(found)
}

/// Partners at `r_i + r_j` apart give or take a few ulps, around `base`, on a layout that
/// holds them or only some of them (`cells` of `width` from `corner`): the prefilter passes
/// every one the exact test takes, and the cells around the first hold every partner's cell.
fn holds_every_exact_pair<V: Vector>(
    base: V,
    radii: [f64; 2],
    directions: &[V],
    nudge: f64,
    (corner, width, cells): (V, f64, usize),
) {
    let reach = radii[0] + radii[1];
    let mut positions = vec![base];
    let mut all_radii = vec![radii[0]];
    for &d in directions {
        let length = d.length_squared().sqrt();
        if length == 0.0 || !length.is_finite() {
            continue;
        }
        positions.push(base + d * (reach * (1.0 + nudge) / length));
        all_radii.push(radii[1]);
    }
    let far = corner + V::from_slice(&[width * cells as f64; 3]);
    let layout = layout(Aabb::new(corner, far).expect("a box"), cells);
    let (packed, planar) = packed(&positions, &all_radii, &layout).expect("in range");
    let mut found = Vec::new();
    let probe = packed.probe::<V>(&planar, 0);
    packed.scan::<V>(&planar, probe, (1, positions.len()), &mut |k| found.push(k));
    let (firsts, lasts) = packed.cells_around(&planar, 0, layout.cells[0] - 1);
    for k in 1..positions.len() {
        if is_overlapping(positions[0], positions[k], all_radii[0], all_radii[k]) {
            assert!(found.contains(&k), "{k}: {positions:?} {all_radii:?}");
            let cell = layout.axis_cell(0, positions[k].get(0)) as i32;
            assert!((firsts[0]..=lasts[0]).contains(&cell), "{k}: cell {cell}");
        }
    }
}

proptest::proptest! {
    /// In 2D (the first two of each three numbers) and in 3D.
    #[test]
    fn the_prefilter_passes_every_pair_the_exact_test_takes(
        base in proptest::array::uniform3(-1e3f64..1e3),
        scale in proptest::sample::select(vec![1e-6, 1e-3, 1.0, 1e3, 1e6]),
        radii in proptest::array::uniform2(0.0f64..1.0),
        directions in proptest::collection::vec(proptest::array::uniform3(-1.0f64..1.0), 1..20),
        nudge in -1e-6f64..1e-6,
        corner in proptest::array::uniform3(-1.2e3f64..1e3),
        (width, cells) in (0.01f64..100.0, 1usize..3000),
    ) {
        let radii = radii.map(|r| r * scale);
        let flat = |v: [f64; 3]| DVec2::new(v[0], v[1]);
        let grid = (flat(corner) * scale, width * scale, cells);
        let directions_2d: Vec<DVec2> = directions.iter().map(|&d| flat(d)).collect();
        holds_every_exact_pair(flat(base) * scale, radii, &directions_2d, nudge, grid);
        let grid = (DVec3::from(corner) * scale, width * scale, cells.div_ceil(10));
        let directions_3d: Vec<DVec3> = directions.into_iter().map(DVec3::from).collect();
        holds_every_exact_pair(DVec3::from(base) * scale, radii, &directions_3d, nudge, grid);
    }
}

fn unit_box() -> GridLayout {
    layout(
        Aabb::new(DVec2::splat(-10.0), DVec2::splat(10.0)).unwrap(),
        10,
    )
}

#[test]
fn far_apart_particles_do_not_pass() {
    let positions = [DVec2::ZERO, DVec2::new(3.0, 0.0), DVec2::new(0.0, -2.1)];
    assert_eq!(passed(&positions, &[1.0; 3], &unit_box()), Some(vec![]));
    let positions = [DVec2::ZERO, DVec2::new(1.9, 0.0), DVec2::new(0.0, -2.1)];
    assert_eq!(passed(&positions, &[1.0; 3], &unit_box()), Some(vec![1]));
}

#[test]
fn a_run_is_cut_at_its_end_not_at_the_lanes() {
    // (twelve touching particles: a run of five takes five, whatever lies after it)
    let positions = vec![DVec2::ZERO; 12];
    let (packed, planar) = packed(&positions, &[1.0; 12], &unit_box()).unwrap();
    let probe = packed.probe::<DVec2>(&planar, 0);
    let mut found = Vec::new();
    packed.scan::<DVec2>(&planar, probe, (3, 8), &mut |k| found.push(k));
    assert_eq!(found, vec![3, 4, 5, 6, 7]);
    found.clear();
    packed.scan::<DVec2>(&planar, probe, (2, 12), &mut |k| found.push(k));
    assert_eq!(found, (2..12).collect::<Vec<_>>());
    found.clear();
    packed.scan::<DVec2>(&planar, probe, (12, 12), &mut |k| found.push(k));
    assert_eq!(found, vec![]);
}

#[test]
fn a_copy_that_would_not_hold_every_pair_is_not_taken() {
    let near = DVec2::new(1.0, 0.0);
    let grid = unit_box();
    assert!(packed(&[DVec2::ZERO, near], &[1.0, 1.0], &grid).is_some());
    // (far outside the layout: clamped, as the cells clamp)
    assert!(packed(&[DVec2::new(1e300, 0.0), near], &[1.0, 1.0], &grid).is_some());
    assert!(packed(&[DVec2::ZERO, near], &[-1.0, 1.0], &grid).is_none());
    assert!(packed(&[DVec2::ZERO, near], &[f64::INFINITY, 1.0], &grid).is_none());
    let endless = Aabb {
        min: DVec2::ZERO,
        max: DVec2::new(f64::INFINITY, 1.0),
    };
    assert!(packed(&[DVec2::ZERO, near], &[1.0, 1.0], &layout(endless, 4)).is_none());
    // (a radius over the largest the copy was told of takes more steps than a byte holds)
    let ids = [0, 1];
    let (mut copy, mut planar) = (Packed::default(), PlanarUnits::new());
    let over = (&[DVec2::ZERO, near][..], &[1.0, 1.0][..], 0.5);
    assert!(!copy.fill(over, &ids, &grid, &mut planar, false));
}

#[test]
fn the_parallel_copy_is_the_serial_one() {
    let (positions, radii) = crate::grid::tests::lattice_with_jitter(3 * CHUNK + 17);
    let ids: Vec<u32> = (0..positions.len() as u32).rev().collect();
    let bounds = Aabb::new(DVec3::splat(-15.0), DVec3::splat(15.0)).unwrap();
    let grid = layout(bounds, 30);
    let largest = radii.iter().copied().fold(0.0, f64::max);
    let copy = |parallel: bool| {
        let (mut packed, mut planar) = (Packed::default(), PlanarUnits::new());
        let all = (&positions[..], &radii[..], largest);
        assert!(packed.fill(all, &ids, &grid, &mut planar, parallel));
        (planar, packed.z, packed.reach)
    };
    assert_eq!(copy(false), copy(true));
}
