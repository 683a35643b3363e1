//! The search from one side against brute force: in 2D and 3D, cells as wide as it needs and
//! narrower, by sizes, and across periodic seams.

use crate::broadphase::{BroadPhase, CellScratch, Pair};
use crate::brute::BruteForce;
use crate::domain::Aabb;
use crate::grid::Grid;
use crate::periodic::Periodic;
use crate::vector::Vector;
use glam::{DVec2, DVec3};

/// A cloud of `n` particles in (-20, 20) on every axis, radii 0.5 and 1.5.
fn cloud<V: Vector>(n: usize, seed: u64) -> (Vec<V>, Vec<f64>) {
    let mut next = crate::testing::uniform(seed);
    let positions = (0..n)
        .map(|_| V::from_slice(&[0.0; 3].map(|_: f64| next() * 40.0 - 20.0)))
        .collect();
    let radii = (0..n).map(|i| if i % 5 == 0 { 1.5 } else { 0.5 }).collect();
    (positions, radii)
}

/// Asserts that `grid` finds `expected` among `positions`, and keeps `kept` of them with
/// `keep`.
fn assert_finds<V: Vector>(
    grid: &mut Grid<V>,
    (positions, radii): (&[V], &[f64]),
    (expected, kept): (&[Pair], &[Pair]),
    keep: &(dyn Fn(Pair) -> bool + Sync),
    label: &str,
) {
    let (mut got, mut scratch, mut retained) = (Vec::new(), CellScratch::default(), Vec::new());
    grid.find_pairs(positions, radii, &mut got);
    assert_eq!(got, expected, "{label}");
    grid.find_pairs_kept_in(
        positions,
        radii,
        keep,
        &mut got,
        &mut scratch,
        &mut retained,
    );
    assert_eq!(got, kept, "{label}, keeping some");
}

/// Brute force's pairs among `positions`, and those of them `keep` holds for.
fn brute_force<V: Vector>(
    mut brute: BruteForce,
    positions: &[V],
    radii: &[f64],
    keep: &dyn Fn(Pair) -> bool,
) -> (Vec<Pair>, Vec<Pair>) {
    let mut expected = Vec::new();
    brute.find_pairs(positions, radii, &mut expected);
    let kept = expected
        .iter()
        .copied()
        .filter(|&pair| keep(pair))
        .collect();
    (expected, kept)
}

/// The search from one side finds exactly brute force's pairs (and, keeping some, what a
/// retain after it keeps), in 2D and 3D, with cells exactly as wide as it needs and wider,
/// with particles clamped into the border cells.
fn finds_what_brute_force_finds<V: Vector>() {
    let (positions, radii) = cloud::<V>(3000, 7);
    let keep = |(i, j): Pair| (i + 2 * j) % 3 != 1;
    let (expected, kept) = brute_force(BruteForce::new(), &positions, &radii, &keep);
    // (a domain a little inside the cloud: its border cells take the few particles beyond)
    let domain = Aabb::new(V::from_slice(&[-19.9; 3]), V::from_slice(&[19.9; 3])).unwrap();
    for cells in [1, 5, 13] {
        let mut grid = Grid::new(Some(domain), Some(&vec![cells; V::DIM])).unwrap();
        let found = (&expected[..], &kept[..]);
        assert_finds(
            &mut grid,
            (&positions, &radii),
            found,
            &keep,
            &format!("{cells} cells"),
        );
        assert!(grid.searches_from_one_side(1.5));
        assert_eq!(BroadPhase::<V>::name(&grid), "grid");
    }
    // (13 cells of 39.8 / 13 = 3.06 hold pairs of radius 1.5 to neighbours;
    // 14 of 2.84 hold them 2 cells apart, 27 of 1.47 and 30 of 1.33 3 apart, searched
    // from one side all the same; 40 of 0.995 hold them 4 apart, searched particle by
    // particle)
    for (cells, apart) in [(14, 2), (27, 3), (30, 3), (40, 4)] {
        let mut grid = Grid::<V>::new(Some(domain), Some(&vec![cells; V::DIM])).unwrap();
        let mut got = Vec::new();
        grid.find_pairs(&positions, &radii, &mut got);
        assert_eq!(grid.layout().cells_apart::<V>(1.5), apart, "{cells} cells");
        assert!(!grid.layout().holds_pairs_to_neighbours::<V>(1.5));
        assert_eq!(
            grid.searches_from_one_side(1.5),
            apart <= 3,
            "{cells} cells"
        );
        assert_eq!(got, expected, "{cells} cells, {apart} apart");
        assert!(
            !grid.searches_from_one_side(f64::NAN),
            "a radius not a number"
        );
    }
}

/// With a few large particles among many small ones in cells that hold only the small
/// ones' pairs to a few cells apart, the search by sizes finds exactly brute force's pairs.
fn finds_by_sizes_what_brute_force_finds<V: Vector>() {
    let (positions, _) = cloud::<V>(3000, 11);
    let radii: Vec<f64> = (0..3000)
        .map(|i| if i % 40 == 0 { 2.5 } else { 0.5 })
        .collect();
    let keep = |(i, j): Pair| (i + 2 * j) % 3 != 1;
    let (expected, kept) = brute_force(BruteForce::new(), &positions, &radii, &keep);
    assert!(expected.iter().any(|&(i, j)| i % 40 == 0 && j % 40 == 0));
    let domain = Aabb::new(V::from_slice(&[-19.9; 3]), V::from_slice(&[19.9; 3])).unwrap();
    // (cells of 0.6: the small pairs 2 cells apart, the large 9)
    let mut grid = Grid::new(Some(domain), Some(&vec![66; V::DIM])).unwrap();
    let found = (&expected[..], &kept[..]);
    assert_finds(&mut grid, (&positions, &radii), found, &keep, "by sizes");
    assert!(!grid.searches_from_one_side(2.5));
    assert_eq!(grid.small_radius(&radii), Some(0.5));
    // (one large in 7: particle by particle)
    let crowded: Vec<f64> = (0..3000)
        .map(|i| if i % 7 == 0 { 2.5 } else { 0.5 })
        .collect();
    assert_eq!(grid.small_radius(&crowded), None);
}

#[test]
fn the_search_by_sizes_finds_what_brute_force_finds() {
    finds_by_sizes_what_brute_force_finds::<DVec2>();
    finds_by_sizes_what_brute_force_finds::<DVec3>();
}

/// Across periodic seams too, with as few as three cells on a wrapping axis (a cell's
/// neighbours on both sides then wrap to the same row's two other cells), and with enough
/// on every wrapping axis for the cells away from the seams to test without the minimum
/// image (see `Forward::at_seam`).
fn finds_across_seams_what_brute_force_finds<V: Vector>() {
    let domain = Aabb::new(V::from_slice(&[-20.0; 3]), V::from_slice(&[20.0; 3])).unwrap();
    let (positions, radii) = cloud::<V>(3000, 8);
    let keep = |(i, j): Pair| (2 * i + j) % 3 != 1;
    for axes in [
        [true, false, false],
        [true, true, true],
        [false, true, true],
    ] {
        let periodic = Periodic::new(&domain, &axes);
        let positions: Vec<V> = positions
            .iter()
            .map(|&x| periodic.unwrap().wrap(x))
            .collect();
        let brute = BruteForce::new().with_periodic(periodic);
        let (expected, kept) = brute_force(brute, &positions, &radii, &keep);
        for cells in [
            [3, 3, 3],
            [4, 3, 5],
            [13, 5, 3],
            [7, 13, 4],
            [6, 13, 7],
            [13; 3],
        ] {
            let cells = &cells[..V::DIM];
            let grid = Grid::new(Some(domain), Some(cells)).unwrap();
            let mut grid = grid.with_periodic(periodic);
            let found = (&expected[..], &kept[..]);
            let label = format!("{axes:?}, cells {cells:?}");
            assert_finds(&mut grid, (&positions, &radii), found, &keep, &label);
            assert!(grid.searches_from_one_side(1.5), "{label}");
        }
    }
}

#[test]
fn the_search_from_one_side_finds_across_seams_what_brute_force_finds() {
    finds_across_seams_what_brute_force_finds::<DVec2>();
    finds_across_seams_what_brute_force_finds::<DVec3>();
}

#[test]
fn the_search_from_one_side_finds_what_brute_force_finds_2d() {
    finds_what_brute_force_finds::<DVec2>();
}

#[test]
fn the_search_from_one_side_finds_what_brute_force_finds_3d() {
    finds_what_brute_force_finds::<DVec3>();
}
