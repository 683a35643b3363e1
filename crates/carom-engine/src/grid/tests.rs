use super::*;
use crate::brute::BruteForce;
use glam::{DVec2, DVec3};

/// The lecture's "Indexing Example": space (-10,-10)..(10,10), 5x5 cells,
/// particle at (-8, 5) goes to cell (0, 3).
#[test]
fn lecture_indexing_example() {
    let domain = Aabb::new(DVec2::splat(-10.0), DVec2::splat(10.0)).unwrap();
    let mut grid = Grid::new(Some(domain), Some(&[5, 5])).unwrap();
    let mut pairs = Vec::new();
    grid.find_pairs(&[DVec2::new(-8.0, 5.0)], &[0.5], &mut pairs);
    assert_eq!(grid.layout().cell_coords(DVec2::new(-8.0, 5.0)), [0, 3, 0]);
    assert_eq!(grid.bucket([0, 3, 0]), &[0]);
    // clamping: far outside lands on the border cells
    assert_eq!(grid.layout().cell_coords(DVec2::new(-1e9, 1e9)), [0, 4, 0]);
    assert_eq!(
        grid.layout().cell_coords(DVec2::new(10.0, -10.0)),
        [4, 0, 0]
    );
}

#[test]
fn zero_or_wrong_cells_are_rejected() {
    assert!(Grid::<DVec2>::new(None, Some(&[0, 4])).is_err());
    assert!(Grid::<DVec2>::new(None, Some(&[4, 4, 4])).is_err());
    assert!(Grid::<DVec3>::new(None, Some(&[1 << 20, 1 << 20, 2])).is_err());
}

pub(super) fn lattice_with_jitter(n: usize) -> (Vec<DVec3>, Vec<f64>) {
    // a deterministic cloud with mixed radii and some coincident centres
    let mut pos = Vec::new();
    let mut rad = Vec::new();
    let mut next = crate::testing::uniform(12345);
    for i in 0..n {
        pos.push(DVec3::new(
            next() * 30.0 - 15.0,
            next() * 30.0 - 15.0,
            next() * 30.0 - 15.0,
        ));
        rad.push(if i % 7 == 0 { 3.0 } else { 1.0 });
    }
    pos.push(pos[0]);
    rad.push(1.0);
    (pos, rad)
}

#[test]
fn grid_equals_brute_force_for_any_cell_size() {
    let (pos, rad) = lattice_with_jitter(600);
    let mut expected = Vec::new();
    BruteForce::new().find_pairs(&pos, &rad, &mut expected);
    assert!(!expected.is_empty());
    // a domain smaller than the cloud, so clamping is exercised too
    let domain = Aabb::new(DVec3::splat(-12.0), DVec3::splat(12.0)).unwrap();
    for cells in [[1, 1, 1], [3, 5, 7], [12, 12, 12], [40, 40, 40]] {
        for d in [Some(domain), None] {
            let mut got = Vec::new();
            Grid::new(d, Some(&cells))
                .unwrap()
                .find_pairs(&pos, &rad, &mut got);
            assert_eq!(got, expected, "cells {cells:?}");
        }
    }
    let mut got = Vec::new();
    Grid::new(None, None)
        .unwrap()
        .find_pairs(&pos, &rad, &mut got);
    assert_eq!(got, expected, "derived cells");
}

/// A search that keeps some pairs keeps what the search and a retain after it keep: in the
/// domain's cells, with many particles outside it (the hash), and periodic, for any cell
/// size (`keep` is tested inside the grid's own searches).
#[test]
fn a_search_keeping_some_pairs_keeps_what_a_retain_keeps() {
    let (pos, rad) = lattice_with_jitter(600);
    let keep = |(i, j): Pair| (i * 31 + j * 17) % 3 != 0;
    let mut expected = Vec::new();
    BruteForce::new().find_pairs(&pos, &rad, &mut expected);
    expected.retain(|&pair| keep(pair));
    let (mut scratch, mut kept) = (CellScratch::default(), Vec::new());
    let domain = Aabb::new(DVec3::splat(-15.0), DVec3::splat(15.0)).unwrap();
    let outside = Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0)).unwrap();
    for cells in [[1, 1, 1], [3, 5, 7], [12, 12, 12], [40, 40, 40]] {
        for (d, hash) in [(domain, false), (outside, true)] {
            let mut got = Vec::new();
            let mut grid = Grid::new(Some(d), Some(&cells)).unwrap();
            grid.find_pairs_kept_in(&pos, &rad, &keep, &mut got, &mut scratch, &mut kept);
            assert_eq!(got, expected, "cells {cells:?}");
            assert_eq!(BroadPhase::<DVec3>::name(&grid).contains("hash"), hash);
        }
    }
    let periodic = crate::periodic::Periodic::new(&domain, &[true, false, true]);
    let pos: Vec<DVec3> = pos.iter().map(|&x| periodic.unwrap().wrap(x)).collect();
    let mut expected = Vec::new();
    BruteForce::new()
        .with_periodic(periodic)
        .find_pairs(&pos, &rad, &mut expected);
    expected.retain(|&pair| keep(pair));
    for cells in [[1, 1, 1], [3, 5, 7], [12, 12, 12]] {
        let mut got = Vec::new();
        let grid = Grid::new(Some(domain), Some(&cells)).unwrap();
        let mut grid = grid.with_periodic(periodic);
        grid.find_pairs_kept_in(&pos, &rad, &keep, &mut got, &mut scratch, &mut kept);
        assert_eq!(got, expected, "periodic, cells {cells:?}");
    }
}

/// A search in lent arrays finds the same pairs, and the grid keeps none of its own.
#[test]
fn a_search_in_lent_arrays_finds_the_same_pairs() {
    let (pos, rad) = lattice_with_jitter(600);
    let mut expected = Vec::new();
    Grid::new(None, None)
        .unwrap()
        .find_pairs(&pos, &rad, &mut expected);
    let mut grid = Grid::new(None, None).unwrap();
    let mut scratch = CellScratch::default();
    for _ in 0..2 {
        let mut got = Vec::new();
        grid.find_pairs_in(&pos, &rad, &mut got, &mut scratch);
        assert_eq!(got, expected);
    }
    let own = grid.cell_of.capacity() + grid.cell_start.capacity() + grid.ids.capacity();
    assert_eq!(own, 0);
    assert_eq!(scratch.keys.len(), pos.len());
}

proptest::proptest! {
    /// A coordinate's cell is its cell index truncated and then clamped to the axis, whatever
    /// the coordinate: beyond either end, infinite or NaN (which goes to cell 0). (The clamp
    /// is taken on the float, before the truncation, which costs less.)
    #[test]
    fn a_coordinate_goes_to_its_truncated_cell_clamped_to_the_axis(
        coordinate in proptest::prop_oneof![
            -1e3f64..1e3,
            proptest::num::f64::ANY,
            proptest::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, 0.0]),
        ],
        origin in -50.0f64..50.0,
        size in 0.01f64..10.0,
        cells in 1usize..5000,
    ) {
        let layout = GridLayout {
            origin: [origin; 3],
            cell_size: [size; 3],
            inverse_cell_size: [1.0 / size; 3],
            cells: [cells; 3],
        };
        let t = (coordinate - origin) * (1.0 / size);
        let truncated_then_clamped = (t as i64).clamp(0, cells as i64 - 1) as usize;
        proptest::prop_assert_eq!(layout.axis_cell(0, coordinate), truncated_then_clamped);
    }
}
