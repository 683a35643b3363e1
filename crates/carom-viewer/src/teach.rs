//! The lecture's pictures: the hash grid, a particle's neighbour cells, the candidates found
//! there, its actual contacts, and a contact's normal/tangent velocity split.

use carom_engine::glam::DVec3;
use carom_engine::grid::GridLayout;
use carom_engine::response::{contact_normal, split_normal_tangent, NormalTangent};
use carom_engine::{Aabb, Pair};

/// The grid to draw: the broad phase's own when it is the lecture's grid (same box, same
/// cells), otherwise the grid the lecture would use (cells one largest diameter wide, at most
/// one per particle as the engine's derived grids: [`carom_engine::grid::cell_limit`]) over the
/// domain or, without one, over the particles' bounding box.
pub fn layout_for(
    dims: usize,
    domain: Option<(DVec3, DVec3)>,
    positions: &[DVec3],
    max_radius: f64,
    cells: Option<[usize; 3]>,
) -> GridLayout {
    let (min, max) = domain.unwrap_or_else(|| {
        positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    });
    let (min, max) = if min.is_finite() && max.is_finite() {
        (min, max)
    } else {
        (DVec3::ZERO, DVec3::ONE)
    };
    let limit = carom_engine::grid::cell_limit(positions.len()).min(1e6);
    let max_radius = if max_radius.is_finite() && max_radius > 0.0 {
        max_radius
    } else {
        1.0
    };
    if dims == 2 {
        let b = Aabb {
            min: min.truncate(),
            max: max.truncate(),
        };
        GridLayout::fit(&b, max_radius, cells, limit)
    } else {
        GridLayout::fit(&Aabb { min, max }, max_radius, cells, limit)
    }
}

/// The lecture's hash of one position (normalise, scale, clamp, floor).
pub fn cell_of(layout: &GridLayout, dims: usize, p: DVec3) -> [usize; 3] {
    let mut c = [0; 3];
    for (a, slot) in c.iter_mut().enumerate().take(dims) {
        *slot = layout.axis_cell(a, p.to_array()[a]);
    }
    c
}

/// What the hash grid does for one particle.
#[derive(Clone, Debug, PartialEq)]
pub struct Neighbourhood {
    /// The particle.
    pub id: usize,
    /// Its cell.
    pub cell: [usize; 3],
    /// First and last neighbour cell per axis (inclusive): the block the grid searches.
    pub lo: [usize; 3],
    /// See `lo`.
    pub hi: [usize; 3],
    /// Every other particle in those cells: what the grid tests (ascending ids).
    pub candidates: Vec<usize>,
    /// The particles it actually touches, from the engine's last step (ascending ids).
    pub contacts: Vec<usize>,
}

/// The neighbour cells of particle `id` (reach: its radius plus the largest radius, as the
/// engine's grid searches), the candidate particles found in them, and its contacts from
/// `contacts` (id pairs). `None` for an id out of range.
pub fn neighbourhood(
    layout: &GridLayout,
    dims: usize,
    positions: &[DVec3],
    radii: &[f64],
    contacts: &[Pair],
    id: usize,
) -> Option<Neighbourhood> {
    let p = *positions.get(id)?;
    let max_radius = radii.iter().copied().fold(0.0, f64::max);
    let reach = radii[id] + max_radius;
    let (mut lo, mut hi) = ([0; 3], [0; 3]);
    for a in 0..dims {
        (lo[a], hi[a]) = layout.axis_range(a, p.to_array()[a], reach);
    }
    let inside = |c: [usize; 3]| (0..dims).all(|a| lo[a] <= c[a] && c[a] <= hi[a]);
    let candidates = positions
        .iter()
        .enumerate()
        .filter(|&(j, &q)| j != id && inside(cell_of(layout, dims, q)))
        .map(|(j, _)| j)
        .collect();
    let mut touching: Vec<usize> = contacts
        .iter()
        .filter_map(|&(a, b)| match (a as usize, b as usize) {
            (a, b) if a == id => Some(b),
            (a, b) if b == id => Some(a),
            _ => None,
        })
        .collect();
    touching.sort_unstable();
    Some(Neighbourhood {
        id,
        cell: cell_of(layout, dims, p),
        lo,
        hi,
        candidates,
        contacts: touching,
    })
}

/// One contact seen the lecture's way: the unit normal from particle `b` to particle `a`, and
/// each velocity split into its normal and tangent part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSplit {
    /// Unit normal, from `b` towards `a`.
    pub normal: DVec3,
    /// Centre distance.
    pub distance: f64,
    /// `a`'s velocity split.
    pub a: NormalTangent<DVec3>,
    /// `b`'s velocity split.
    pub b: NormalTangent<DVec3>,
    /// True when they approach (`p_rel . v_rel < 0`): the engine responds.
    pub approaching: bool,
}

/// [`ContactSplit`] for particles at `pa`, `pb` moving at `va`, `vb`.
pub fn contact_split(pa: DVec3, va: DVec3, pb: DVec3, vb: DVec3) -> ContactSplit {
    let (normal, distance) = contact_normal(pa, pb);
    ContactSplit {
        normal,
        distance,
        a: split_normal_tangent(va, normal),
        b: split_normal_tangent(vb, normal),
        approaching: carom_engine::response::is_approaching(pa, pb, va, vb),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lecture_layout() -> GridLayout {
        // The lecture's indexing example: (-10,-10)..(10,10), 5x5 cells of size 4.
        layout_for(
            2,
            Some((DVec3::new(-10.0, -10.0, 0.0), DVec3::new(10.0, 10.0, 0.0))),
            &[],
            0.5,
            Some([5, 5, 1]),
        )
    }

    #[test]
    fn lecture_indexing_example() {
        let l = lecture_layout();
        assert_eq!(l.cells, [5, 5, 1]);
        assert_eq!(cell_of(&l, 2, DVec3::new(-8.0, 5.0, 0.0)), [0, 3, 0]);
        assert_eq!(cell_of(&l, 2, DVec3::new(1e9, -1e9, 0.0)), [4, 0, 0]);
    }

    #[test]
    fn neighbourhood_is_the_3x3_block_with_its_candidates_and_contacts() {
        let l = lecture_layout(); // cells 4 wide; radius 1.5 -> reach 3 < one cell
        let positions = [
            DVec3::new(1.0, 1.0, 0.0),   // 0: cell (2, 2), the red one
            DVec3::new(3.5, 1.0, 0.0),   // 1: cell (3, 2), touching 0
            DVec3::new(-5.0, -5.0, 0.0), // 2: cell (1, 1), a candidate only
            DVec3::new(9.0, 9.0, 0.0),   // 3: cell (4, 4), not a neighbour
        ];
        let radii = [1.5; 4];
        let contacts = [(0, 1)];
        let n = neighbourhood(&l, 2, &positions, &radii, &contacts, 0).unwrap();
        assert_eq!(n.cell, [2, 2, 0]);
        assert_eq!((n.lo, n.hi), ([1, 1, 0], [3, 3, 0]));
        assert_eq!(n.candidates, vec![1, 2]);
        assert_eq!(n.contacts, vec![1]);
        let n1 = neighbourhood(&l, 2, &positions, &radii, &contacts, 1).unwrap();
        assert_eq!(n1.contacts, vec![0]);
        assert!(neighbourhood(&l, 2, &positions, &radii, &contacts, 9).is_none());
    }

    #[test]
    fn big_neighbours_widen_the_block() {
        // the lecture's mixed radii demo: a radius-3 particle elsewhere widens the search
        let l = lecture_layout();
        let positions = [DVec3::new(1.0, 1.0, 0.0), DVec3::new(-9.0, -9.0, 0.0)];
        let n = neighbourhood(&l, 2, &positions, &[0.5, 3.0], &[], 0).unwrap();
        assert_eq!((n.lo, n.hi), ([1, 1, 0], [3, 3, 0]));
        let n = neighbourhood(&l, 2, &positions, &[0.5, 8.0], &[], 0).unwrap();
        assert_eq!((n.lo, n.hi), ([0, 0, 0], [4, 4, 0]));
    }

    #[test]
    fn three_d_neighbourhood() {
        let l = layout_for(
            3,
            Some((DVec3::splat(-3.0), DVec3::splat(3.0))),
            &[],
            1.0,
            None,
        );
        assert_eq!(l.cells, [3, 3, 3]);
        // cells 2 wide; reach 0.8 from 0.9 spans 0.1..1.7: cells 1 and 2 on each axis
        let positions = [DVec3::splat(0.9), DVec3::splat(2.5), DVec3::splat(-2.5)];
        let n = neighbourhood(&l, 3, &positions, &[0.4; 3], &[], 0).unwrap();
        assert_eq!((n.cell, n.lo, n.hi), ([1, 1, 1], [1, 1, 1], [2, 2, 2]));
        assert_eq!(n.candidates, vec![1]);
    }

    #[test]
    fn layout_without_domain_or_particles_is_sane() {
        let l = layout_for(2, None, &[], 0.0, None);
        assert!(l.total() >= 1 && l.cell_size.iter().all(|s| s.is_finite() && *s > 0.0));
    }

    #[test]
    fn lecture_example_2_split() {
        // p2 - p1 along the lecture's normal (sqrt3/2, -1/2); v1 = (20, 0), v2 = (-10, 0)
        let n = DVec3::new(3f64.sqrt() / 2.0, -0.5, 0.0);
        let s = contact_split(
            DVec3::ZERO,
            DVec3::new(20.0, 0.0, 0.0),
            n * 1.9,
            DVec3::new(-10.0, 0.0, 0.0),
        );
        assert!((s.normal + n).length() < 1e-12);
        assert!((s.a.normal - DVec3::new(15.0, -5.0 * 3f64.sqrt(), 0.0)).length() < 1e-9);
        assert!((s.b.tangent - DVec3::new(-2.5, -2.5 * 3f64.sqrt(), 0.0)).length() < 1e-9);
        assert!(s.approaching);
        assert!((s.distance - 1.9).abs() < 1e-12);
    }
}
