//! The bare step of `carom bench`: the lecture's `ParticleSystem_Movement()` once over a case's
//! particles and nothing more, timed in the same process as the case.
//!
//! It moves every particle, bounces it off the planes (`V' = V_T - k V_N`), bins it, finds the
//! pairs that overlap and approach in one search of the cells around it, and gives each pair the
//! lecture's response and a push apart, once, in one serial pass. It has none of carom's own
//! work: no reaches swept to the step's motion, no second search, no solver sweeps, no sleep,
//! no sort of its pairs into one order (they come in the walk's, which no thread count
//! changes). Its state is kept in cell order, as the CUDA "particles" sample keeps it, so its
//! search reads memory in sequence and through no index.
//!
//! It is not a correct engine (a pile under it sinks, and two particles that cross within one
//! step are never seen to meet), only the cheapest step that looks like one that we could
//! write; not a proven bound. Between the streaming floor (one pass over memory, see
//! `crate::floor`) and the case's own time, it says how much of a step the search by cells
//! and the passes around it cost on this machine at the least we know how to make them, and
//! how much of the rest is carom's.

use carom_engine::bucket::counting_sort_parallel;
use carom_engine::grid::{self, GridLayout};
use carom_engine::response::{collide, contact_normal, is_approaching, is_overlapping};
use carom_engine::{Aabb, Particles, Plane, Vector, World};
use rayon::prelude::*;
use std::time::Instant;

/// Bare steps timed after one untimed; the fastest counts (as the floor's passes).
const STEPS: usize = 5;

/// Particles per parallel task of the move.
const CHUNK: usize = 8192;

/// Rows of cells per parallel task of the search.
const ROWS_PER_TASK: usize = 16;

/// Nanoseconds per particle of the fastest of [`STEPS`] bare steps over a copy of `world`'s
/// particles, planes, gravity, dt and restitution, stepped on the current rayon pool from one
/// of its threads (as `carom run` steps).
pub fn bare_step_ns<V: Vector>(world: &World<V>) -> f64 {
    let mut bare = Bare::new(world);
    rayon::scope(|_| {
        bare.step();
        let mut best = f64::INFINITY;
        for _ in 0..STEPS {
            let started = Instant::now();
            bare.step();
            best = best.min(started.elapsed().as_secs_f64());
        }
        best * 1e9 / bare.position.len().max(1) as f64
    })
}

/// The bare step's state, in cell order after each bin.
struct Bare<V: Vector> {
    position: Vec<V>,
    velocity: Vec<V>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    planes: Vec<Plane<V>>,
    gravity: V,
    dt: f64,
    restitution: f64,
    cells: GridLayout,
    /// Each particle's cell.
    key: Vec<u32>,
    /// Where the particle now `i`-th in cell order was before the bin.
    from: Vec<u32>,
    /// `start[c]..start[c + 1]` are the particles of cell `c`.
    start: Vec<u32>,
    /// The counting sort's scratch.
    totals: Vec<u32>,
    spare_vector: Vec<V>,
    spare_scalar: Vec<f64>,
    /// The search's pairs (indices in cell order, lower first), one list per task.
    pairs: Vec<Vec<(u32, u32)>>,
}

/// The bare step's fixed grid: the engine's own layout (the lecture's hash, see
/// [`GridLayout`]) over the world's domain or, without one, the particles' first bounding box,
/// cells at least one largest diameter wide (so every pair lies in neighbouring cells), as many
/// as the engine's own grid would take ([`grid::cell_limit`]). Particles beyond it are clamped
/// into its border cells, and still found.
fn fit_cells<V: Vector>(position: &[V], domain: Option<Aabb<V>>, max_radius: f64) -> GridLayout {
    let bounds = domain.unwrap_or_else(|| grid::bounding_box(position));
    GridLayout::fit(&bounds, max_radius, None, grid::cell_limit(position.len()))
}

/// The cell of `x` in `cells`, as a linear index.
#[inline]
fn cell_key<V: Vector>(cells: &GridLayout, x: V) -> u32 {
    cells.linear(cells.cell_coords(x)) as u32
}

impl<V: Vector> Bare<V> {
    fn new(world: &World<V>) -> Self {
        let config = world.config();
        let setting = (config.gravity, config.dt, config.restitution);
        Self::with(world.particles(), config.domain, world.planes(), setting)
    }

    /// A copy of `particles` and `planes`, binned over `domain` (see [`fit_cells`]), stepped
    /// with `(gravity, dt, restitution)`.
    fn with(
        particles: &Particles<V>,
        domain: Option<Aabb<V>>,
        planes: &[Plane<V>],
        (gravity, dt, k): (V, f64, f64),
    ) -> Self {
        let n = particles.len();
        Bare {
            position: particles.positions().to_vec(),
            velocity: particles.velocities().to_vec(),
            radius: particles.radii().to_vec(),
            mass: particles.masses().to_vec(),
            planes: planes.to_vec(),
            gravity,
            dt,
            restitution: k,
            cells: fit_cells(particles.positions(), domain, particles.max_radius()),
            key: vec![0; n],
            from: vec![0; n],
            start: Vec::new(),
            totals: Vec::new(),
            spare_vector: vec![V::ZERO; n],
            spare_scalar: vec![0.0; n],
            pairs: Vec::new(),
        }
    }

    fn step(&mut self) {
        self.move_and_key();
        self.bin();
        self.search();
        self.respond();
    }

    /// Gravity, the move, the planes' rule and each particle's cell, in one parallel pass.
    fn move_and_key(&mut self) {
        let (gravity, dt, planes, cells) = (self.gravity, self.dt, &self.planes, self.cells);
        self.position
            .par_chunks_mut(CHUNK)
            .zip(self.velocity.par_chunks_mut(CHUNK))
            .zip(
                self.radius
                    .par_chunks(CHUNK)
                    .zip(self.key.par_chunks_mut(CHUNK)),
            )
            .for_each(|((x, v), (r, key))| {
                for i in 0..x.len() {
                    v[i] += gravity * dt;
                    x[i] += v[i] * dt;
                    for plane in planes {
                        if plane.is_colliding(x[i], v[i], r[i]) {
                            v[i] = plane.bounce(v[i]);
                            plane.push_out_in_place(&mut x[i], r[i]);
                        }
                    }
                    key[i] = cell_key(&cells, x[i]);
                }
            });
    }

    /// The engine's counting sort by cell (stable, so particles that keep their cell keep
    /// their order), then the state gathered into that order.
    fn bin(&mut self) {
        let parts = rayon::current_num_threads();
        let (cells, start, from) = (self.cells.total(), &mut self.start, &mut self.from);
        counting_sort_parallel(&self.key, cells, parts, start, from, &mut self.totals);
        gather(&mut self.position, &self.from, &mut self.spare_vector);
        gather(&mut self.velocity, &self.from, &mut self.spare_vector);
        gather(&mut self.radius, &self.from, &mut self.spare_scalar);
        gather(&mut self.mass, &self.from, &mut self.spare_scalar);
    }

    /// The pairs that overlap and approach, each found once from the cell that comes first:
    /// the rest of its own cell and the next cell of its row, then the three cells around it
    /// in the next row (and in 3D the next layer's three rows of three).
    fn search(&mut self) {
        let [width, height, depth] = self.cells.cells;
        let rows = height * depth;
        let tasks = rows.div_ceil(ROWS_PER_TASK);
        self.pairs.resize_with(tasks, Vec::new);
        let (position, velocity, radius) = (&self.position, &self.velocity, &self.radius);
        let start = &self.start;
        let run = |row: usize, first: usize, last: usize| {
            let base = row * width;
            (
                start[base + first] as usize,
                start[base + last + 1] as usize,
            )
        };
        let forward_rows: &[(isize, isize)] = if V::DIM == 3 {
            &[(1, 0), (-1, 1), (0, 1), (1, 1)]
        } else {
            &[(1, 0)]
        };
        self.pairs
            .par_iter_mut()
            .enumerate()
            .for_each(|(task, out)| {
                out.clear();
                for row in task * ROWS_PER_TASK..((task + 1) * ROWS_PER_TASK).min(rows) {
                    let (z, y) = (row / height, row % height);
                    for x in 0..width {
                        let (first, end) = run(row, x, x);
                        if first == end {
                            continue;
                        }
                        let own_end = run(row, x, (x + 1).min(width - 1)).1;
                        let mut runs = [(0, 0); 4];
                        let mut count = 0;
                        for &(dy, dz) in forward_rows {
                            let (y, z) = (y as isize + dy, z as isize + dz);
                            if (0..height as isize).contains(&y) && (0..depth as isize).contains(&z)
                            {
                                let row = z as usize * height + y as usize;
                                runs[count] = run(row, x.saturating_sub(1), (x + 1).min(width - 1));
                                count += 1;
                            }
                        }
                        for i in first..end {
                            let (xi, vi, ri) = (position[i], velocity[i], radius[i]);
                            let mut test = |j: usize| {
                                if is_overlapping(xi, position[j], ri, radius[j])
                                    && is_approaching(xi, position[j], vi, velocity[j])
                                {
                                    out.push((i as u32, j as u32));
                                }
                            };
                            (i + 1..own_end).for_each(&mut test);
                            for &(a, b) in &runs[..count] {
                                (a..b).for_each(&mut test);
                            }
                        }
                    }
                }
            });
    }

    /// The lecture's response to each pair found, then a push apart along the normal, mass
    /// weighted, in one serial pass (pairs share particles).
    fn respond(&mut self) {
        let k = self.restitution;
        let (position, velocity) = (&mut self.position, &mut self.velocity);
        let (radius, mass) = (&self.radius, &self.mass);
        for &(i, j) in self.pairs.iter().flatten() {
            let (i, j) = (i as usize, j as usize);
            let (normal, distance) = contact_normal(position[i], position[j]);
            if is_approaching(position[i], position[j], velocity[i], velocity[j]) {
                let (vi, vj) = collide(normal, velocity[i], velocity[j], mass[i], mass[j], k);
                (velocity[i], velocity[j]) = (vi, vj);
            }
            let depth = radius[i] + radius[j] - distance;
            if depth > 0.0 {
                let (wi, wj) = (1.0 / mass[i], 1.0 / mass[j]);
                let share = depth / (wi + wj);
                position[i] += normal * (share * wi);
                position[j] -= normal * (share * wj);
            }
        }
    }
}

/// `values[i] = values[from[i]]` for every `i`, through `spare`.
fn gather<T: Copy + Send + Sync>(values: &mut Vec<T>, from: &[u32], spare: &mut Vec<T>) {
    spare
        .par_iter_mut()
        .zip(from.par_iter())
        .for_each(|(slot, &f)| *slot = values[f as usize]);
    std::mem::swap(values, spare);
}

#[cfg(test)]
mod tests {
    use super::*;
    use carom_engine::glam::{DVec2, DVec3};

    /// `n` particles in (-20, 20) on every axis, radii 0.5 and 1.5, velocities in (-5, 5).
    fn cloud<V: Vector>(n: usize) -> Particles<V> {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut particles = Particles::new();
        for i in 0..n {
            let x = V::from_slice(&[0.0; 3].map(|_: f64| next() * 40.0 - 20.0)[..V::DIM]);
            let v = V::from_slice(&[0.0; 3].map(|_: f64| next() * 10.0 - 5.0)[..V::DIM]);
            let radius = if i % 5 == 0 { 1.5 } else { 0.5 };
            particles.push(x, v, radius, 1.0 + radius).unwrap();
        }
        particles
    }

    /// The search finds exactly the pairs that overlap and approach, by brute force over the
    /// same state, with some particles beyond the cells (clamped into the border ones).
    fn finds_what_brute_force_finds<V: Vector>() {
        let mut bare = Bare::with(&cloud::<V>(3000), None, &[], (V::ZERO, 0.0, 1.0));
        // (a few moved just beyond the cells' +x and -x faces, close enough to the cloud's
        // border and to one another to meet: clamped into the border cells, they must still
        // find their partners)
        for (k, i) in (0..3000).step_by(97).enumerate() {
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let beyond = side * (20.1 + 0.3 * (k % 4) as f64);
            let along = -4.0 + 0.25 * k as f64;
            bare.position[i] = V::from_slice(&[beyond, along, 0.5 * along][..V::DIM]);
        }
        bare.move_and_key();
        bare.bin();
        bare.search();
        let mut found: Vec<(u32, u32)> = bare.pairs.iter().flatten().copied().collect();
        found.sort_unstable();
        let (x, v, r) = (&bare.position, &bare.velocity, &bare.radius);
        let mut expected = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                if is_overlapping(x[i], x[j], r[i], r[j]) && is_approaching(x[i], x[j], v[i], v[j])
                {
                    expected.push((i as u32, j as u32));
                }
            }
        }
        assert!(expected.len() > 100, "{} pairs", expected.len());
        let beyond = |i: u32| x[i as usize].get(0).abs() > 20.0;
        let across = expected.iter().filter(|&&(i, j)| beyond(i) || beyond(j));
        assert!(
            across.count() >= 5,
            "too few pairs beyond the cells to test"
        );
        assert_eq!(found, expected);
    }

    #[test]
    fn the_search_finds_what_brute_force_finds() {
        finds_what_brute_force_finds::<DVec2>();
        finds_what_brute_force_finds::<DVec3>();
    }

    /// A head-on pair gets the lecture's response (momentum kept, at k = 1 energy too) and is
    /// pushed apart to touching; a disc moving into a wall bounces off it.
    #[test]
    fn a_head_on_pair_takes_the_lecture_response() {
        let mut particles = Particles::new();
        particles
            .push(DVec2::new(0.0, 0.0), DVec2::new(2.0, 0.0), 1.0, 1.0)
            .unwrap();
        particles
            .push(DVec2::new(1.5, 0.0), DVec2::new(-1.0, 0.0), 1.0, 3.0)
            .unwrap();
        particles
            .push(DVec2::new(9.0, 0.0), DVec2::new(1.0, 0.0), 1.0, 1.0)
            .unwrap();
        let wall = Plane::new(DVec2::new(9.5, 0.0), DVec2::new(-1.0, 0.0), 1.0).unwrap();
        let mut bare = Bare::with(&particles, None, &[wall], (DVec2::ZERO, 1e-9, 1.0));
        bare.step();
        let (v, m, x) = (&bare.velocity, &bare.mass, &bare.position);
        let momentum = v[0] * m[0] + v[1] * m[1];
        assert!(
            (momentum - DVec2::new(-1.0, 0.0)).length() < 1e-9,
            "{momentum}"
        );
        let energy = 0.5 * (m[0] * v[0].length_squared() + m[1] * v[1].length_squared());
        assert!((energy - 3.5).abs() < 1e-9, "{energy}");
        assert!(v[0].x < 0.0 && v[1].x > 0.0, "{v:?}");
        assert!(((x[1] - x[0]).length() - 2.0).abs() < 1e-9, "{x:?}");
        // (the wall at x = 9.5 facing -x: bounced, and pushed out to touching)
        assert!((v[2] - DVec2::new(-1.0, 0.0)).length() < 1e-12, "{v:?}");
        assert!((x[2].x - 8.5).abs() < 1e-9, "{x:?}");
    }
}
