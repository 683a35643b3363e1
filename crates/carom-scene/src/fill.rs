//! The particle set of a scene: explicit `[[particles]]`, then each `[[fill]]` placed without
//! overlap (random, seeded; or on a lattice).

use crate::raw::{RawArrangement, RawFill, RawScene};
use crate::walls::Walled;
use crate::{Ctx, SceneError};
use carom_engine::{Aabb, Particles, Periodic, Vector};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// What one particle costs while a scene is built and run (engine arrays, grid, contacts and
/// the placement hash), used to refuse fills that cannot fit in memory before trying.
const BYTES_PER_PARTICLE_ESTIMATE: u64 = 256;

/// Densest packings: hexagonal (2D) and face-centred cubic (3D). A fill denser than this
/// cannot exist, so it is refused at once instead of after a long search.
const MAX_PACKING: [f64; 2] = [0.9069, 0.7405];

/// Random placement tries per particle before giving up (on average over the fill).
const ATTEMPTS_PER_PARTICLE: u64 = 200;

/// On periodic axes (`periodic`, of `domain`) every position is wrapped into the domain, as
/// the world would wrap it, and no particle is placed overlapping another across a seam.
pub(crate) fn particles<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    domain: Option<Aabb<V>>,
    periodic: Option<Periodic>,
    walled: Option<Walled<V>>,
) -> Result<Particles<V>, SceneError> {
    let total = check_total(ctx, raw)?;
    let mut out = Particles::new();
    out.try_reserve(total as usize).map_err(|e| {
        ctx.err(
            "fill",
            format!("cannot reserve memory for {total} particles: {e}"),
        )
    })?;
    let mut max_radius = explicit(ctx, raw, periodic, walled.as_ref(), &mut out)?;
    for (i, f) in raw.fill.iter().enumerate() {
        max_radius = max_radius.max(ctx.positive(&format!("fill[{i}].radius"), f.radius)?);
    }
    if raw.fill.is_empty() {
        return Ok(out);
    }
    let (regions, bounds) = regions(ctx, raw, domain, walled.as_ref(), &out)?;
    let mut placer = Placer {
        grid: PlacementGrid::new(bounds, max_radius, total as usize),
        seams: periodic.zip(domain),
    };
    for (id, (&x, &r)) in out.positions().iter().zip(out.radii()).enumerate() {
        placer.grid.insert(x, r, id as u32);
    }
    for (i, f) in raw.fill.iter().enumerate() {
        fill_one(ctx, i, f, regions[i], &mut placer, &mut out)?;
    }
    Ok(out)
}

/// The particles of the whole scene, refused (naming the fill's count) past what carom can
/// index or this machine's memory can hold.
fn check_total(ctx: &Ctx, raw: &RawScene) -> Result<u64, SceneError> {
    let mut total = raw.particles.len() as u64;
    let memory = crate::machine::total_memory_bytes();
    for (i, f) in raw.fill.iter().enumerate() {
        let field = format!("fill[{i}].count");
        if f.count < 1 {
            return Err(ctx.err(field, format!("must be >= 1, got {}", f.count)));
        }
        total = total.saturating_add(f.count as u64);
        if total >= u32::MAX as u64 {
            return Err(ctx.err(
                field,
                format!(
                    "{total} particles in all is more than carom can index ({})",
                    u32::MAX - 1
                ),
            ));
        }
        let need = total.saturating_mul(BYTES_PER_PARTICLE_ESTIMATE);
        if let Some(have) = memory {
            if need > have {
                return Err(ctx.err(
                    field,
                    format!(
                        "{total} particles need about {:.1} GiB, more than this machine's {:.1} GiB of memory",
                        need as f64 / GIB,
                        have as f64 / GIB
                    ),
                ));
            }
        }
    }
    Ok(total)
}

/// The explicit `[[particles]]`, checked and pushed into `out` (wrapped on periodic axes);
/// returns their largest radius.
fn explicit<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    periodic: Option<Periodic>,
    walled: Option<&Walled<V>>,
    out: &mut Particles<V>,
) -> Result<f64, SceneError> {
    let mut max_radius: f64 = 0.0;
    for (i, p) in raw.particles.iter().enumerate() {
        let f = |k: &str| format!("particles[{i}].{k}");
        let position = ctx.vector::<V>(&f("position"), &p.position)?;
        let position = periodic.map_or(position, |w| w.wrap(position));
        let velocity = match &p.velocity {
            Some(v) => ctx.vector::<V>(&f("velocity"), v)?,
            None => V::ZERO,
        };
        let radius = ctx.positive(&f("radius"), p.radius)?;
        let mass = ctx.positive(&f("mass"), p.mass.unwrap_or(1.0))?;
        if let Some(walls) = walled {
            walls.check_particle(ctx, i, position, radius)?;
        }
        max_radius = max_radius.max(radius);
        out.push(position, velocity, radius, mass)
            .map_err(|e| ctx.err(format!("particles[{i}]"), e.to_string()))?;
    }
    Ok(max_radius)
}

/// Each fill's region (its `min` and `max`, else the domain), checked against the walls, and
/// the box around them all and the explicit particles (what the placement grid covers).
fn regions<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    domain: Option<Aabb<V>>,
    walled: Option<&Walled<V>>,
    out: &Particles<V>,
) -> Result<(Vec<Aabb<V>>, Aabb<V>), SceneError> {
    let mut lo = V::from_slice(&[f64::INFINITY; 3]);
    let mut hi = V::from_slice(&[f64::NEG_INFINITY; 3]);
    for &x in out.positions() {
        lo = lo.min_components(x);
        hi = hi.max_components(x);
    }
    let mut regions = Vec::with_capacity(raw.fill.len());
    for (i, f) in raw.fill.iter().enumerate() {
        let region = match (&f.min, &f.max, domain) {
            (Some(lo), Some(hi), _) => ctx.aabb::<V>(&format!("fill[{i}]"), lo, hi)?,
            (None, None, Some(d)) => d,
            (None, None, None) => {
                return Err(ctx.err(
                    format!("fill[{i}]"),
                    "needs a region: give min and max, or a [domain]",
                ))
            }
            _ => return Err(ctx.err(format!("fill[{i}]"), "give both min and max, or neither")),
        };
        if let Some(walls) = walled {
            walls.check_region(ctx, i, &region)?;
        }
        lo = lo.min_components(region.min);
        hi = hi.max_components(region.max);
        regions.push(region);
    }
    Ok((regions, Aabb { min: lo, max: hi }))
}

/// Where particles have been placed so far, and the seams to look across (periodic axes of
/// the domain).
struct Placer<V> {
    grid: PlacementGrid<V>,
    seams: Option<(Periodic, Aabb<V>)>,
}

impl<V: Vector> Placer<V> {
    /// `x` wrapped into the domain on its periodic axes.
    fn wrap(&self, x: V) -> V {
        self.seams.map_or(x, |(p, _)| p.wrap(x))
    }

    /// True when a particle of `radius` at `x` would overlap one already placed, of id
    /// `since` or above (0: any).
    fn overlaps(&self, x: V, radius: f64, since: u32) -> bool {
        match &self.seams {
            None => self.grid.overlaps(x, radius, since),
            Some((p, d)) => self.grid.overlaps_across(p, d, x, radius, since),
        }
    }

    /// For each of `tries`, whether a particle of `radius` there would overlap one already
    /// placed.
    fn refusals(&self, tries: &[V], radius: f64, refused: &mut [bool]) {
        match &self.seams {
            None => self.grid.refusals(tries, radius, refused),
            Some(_) => {
                for (&x, refused) in tries.iter().zip(refused) {
                    *refused = self.overlaps(x, radius, 0);
                }
            }
        }
    }

    /// Pushes a particle into `out` and the grid.
    fn place(
        &mut self,
        ctx: &Ctx,
        i: usize,
        out: &mut Particles<V>,
        (x, v, radius, mass): (V, V, f64, f64),
    ) -> Result<(), SceneError> {
        let id = out
            .push(x, v, radius, mass)
            .map_err(|e| ctx.err(format!("fill[{i}]"), e.to_string()))?;
        self.grid.insert(x, radius, id as u32);
        Ok(())
    }
}

/// One fill's settings, checked.
struct Fill<V> {
    count: u64,
    radius: f64,
    mass: f64,
    speed: f64,
    base_velocity: V,
    region: Aabb<V>,
}

impl<V: Vector> Fill<V> {
    /// A random velocity: the base velocity plus a random direction times a speed uniform in
    /// [0, speed].
    fn velocity(&self, rng: &mut Pcg64) -> V {
        self.base_velocity + random_direction::<V>(rng) * (self.speed * rng.random::<f64>())
    }
}

/// Places the particles of `[[fill]]` `i` (over `region`) into `out`.
fn fill_one<V: Vector>(
    ctx: &Ctx,
    i: usize,
    f: &RawFill,
    region: Aabb<V>,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
) -> Result<(), SceneError> {
    let field = |k: &str| format!("fill[{i}].{k}");
    let radius = f.radius;
    let mass = ctx.positive(&field("mass"), f.mass.unwrap_or(1.0))?;
    let speed = ctx.non_negative(&field("speed"), f.speed.unwrap_or(0.0))?;
    let base_velocity = match &f.velocity {
        Some(v) => ctx.vector::<V>(&field("velocity"), v)?,
        None => V::ZERO,
    };
    let seed = match f.seed {
        None => 0,
        Some(s) if s >= 0 => s as u64,
        Some(s) => return Err(ctx.err(field("seed"), format!("must be >= 0, got {s}"))),
    };
    let extent = region.extent();
    if (0..V::DIM).any(|a| extent.get(a) <= 2.0 * radius) {
        return Err(ctx.err(
            field("radius"),
            format!("a particle of radius {radius} does not fit in the fill region"),
        ));
    }
    let count = f.count as u64;
    let region_volume: f64 = (0..V::DIM).map(|a| extent.get(a)).product();
    let particle_volume = if V::DIM == 2 {
        std::f64::consts::PI * radius * radius
    } else {
        4.0 / 3.0 * std::f64::consts::PI * radius.powi(3)
    };
    let fraction = count as f64 * particle_volume / region_volume;
    if fraction > MAX_PACKING[V::DIM - 2] {
        return Err(ctx.err(
            field("count"),
            format!(
                "{count} particles of radius {radius} would fill {:.0}% of the region, more than the densest packing ({:.0}%)",
                fraction * 100.0,
                MAX_PACKING[V::DIM - 2] * 100.0
            ),
        ));
    }
    let fill = Fill {
        count,
        radius,
        mass,
        speed,
        base_velocity,
        region,
    };
    let mut rng = Pcg64::seed_from_u64(seed);
    match f.arrangement {
        RawArrangement::Random => place_random(ctx, i, &fill, &mut rng, placer, out),
        RawArrangement::Lattice => place_lattice(ctx, i, &fill, &mut rng, placer, out),
    }
}

/// Random tries drawn and checked together (see [`place_random`]). The particles placed do not
/// depend on it: a batch of 1 places the same ones.
const TRIES_PER_BATCH: usize = 65536;

/// Tries per task of a batch's check on the thread pool.
const TRIES_PER_TASK: usize = 512;

/// Tries checked in step within a task: the cell heads of all of them are fetched, then the
/// first particle of each of their cells, then their lists are walked, so that the cache
/// misses of several tries are in flight together instead of one after another.
const TRIES_IN_STEP: usize = 8;

/// How far along the fill's random stream its velocities are drawn: the positions of the tries
/// come from the start of the stream and the velocities from here, so a try's position does
/// not depend on how many tries before it were placed. (No fill comes near 2^100 draws.)
const VELOCITY_STREAM_OFFSET: u128 = 1 << 100;

/// Random positions over the region (less a radius), each kept if it overlaps nothing placed
/// before it: random sequential adsorption, try after try.
///
/// The tries are checked in batches. Every try of a batch is first checked against the
/// particles placed before the batch, on the thread pool (the grid is only read, and the tries
/// are independent, so their cache misses overlap instead of following one another); then,
/// in order, each try that passed is checked against the particles placed earlier in the same
/// batch alone, and placed. A try is placed exactly when it overlaps nothing placed before it,
/// as one try after another would decide, for any batch size or thread count.
fn place_random<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    rng: &mut Pcg64,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
) -> Result<(), SceneError> {
    place_random_in_batches(ctx, i, fill, rng, placer, out, TRIES_PER_BATCH)
}

/// [`place_random`] with `batch` tries checked together.
fn place_random_in_batches<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    rng: &mut Pcg64,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
    batch: usize,
) -> Result<(), SceneError> {
    let (count, radius) = (fill.count, fill.radius);
    let lo = fill.region.min + V::from_slice(&[radius; 3]);
    let span = fill.region.extent() - V::from_slice(&[2.0 * radius; 3]);
    let start = out.len();
    let budget = ATTEMPTS_PER_PARTICLE * count + 10_000;
    let mut velocities = rng.clone();
    velocities.advance(VELOCITY_STREAM_OFFSET);
    let mut attempts = 0u64;
    let mut screen = Screen::default();
    while attempts < budget {
        screen.tries.clear();
        let size = (batch as u64).min(budget - attempts) as usize;
        for _ in 0..size {
            let mut c = [0.0; 3];
            for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
                *slot = lo.get(a) + span.get(a) * rng.random::<f64>();
            }
            screen.tries.push(placer.wrap(V::from_slice(&c)));
        }
        placer.grid.forget_marks();
        let before_batch = out.len() as u32;
        screen.check(placer, radius);
        for (&x, &refused) in screen.tries.iter().zip(&screen.refused) {
            attempts += 1;
            if refused || placer.overlaps(x, radius, before_batch) {
                continue;
            }
            let v = fill.velocity(&mut velocities);
            placer.place(ctx, i, out, (x, v, radius, fill.mass))?;
            if (out.len() - start) as u64 == count {
                return Ok(());
            }
        }
    }
    Err(ctx.err(
        format!("fill[{i}].count"),
        format!(
            "placed only {} of {count} particles without overlap after {budget} random tries; \
             enlarge the region, lower count or radius, or use arrangement = \"lattice\"",
            out.len() - start
        ),
    ))
}

/// A batch of random tries and their check against the particles placed before the batch,
/// with the check's scratch (kept from batch to batch).
#[derive(Default)]
struct Screen<V> {
    tries: Vec<V>,
    /// Whether each try overlaps a particle placed before the batch.
    refused: Vec<bool>,
    /// Each try's cell (high half) and index (low half), sorted.
    by_cell: Vec<u64>,
    sorted: Vec<V>,
    sorted_refused: Vec<bool>,
}

impl<V: Vector> Screen<V> {
    /// Fills `refused` for a particle of `radius` at each try, on the thread pool. The tries
    /// are checked in the order of their cells, so that tries checked one after another read
    /// neighbouring cells (10^6 spheres: 0.91x the time of checking them in the order drawn).
    fn check(&mut self, placer: &Placer<V>, radius: f64) {
        let grid = &placer.grid;
        self.by_cell.clear();
        self.by_cell.extend(
            self.tries
                .iter()
                .enumerate()
                .map(|(k, &x)| ((grid.linear(grid.coords(x)) as u64) << 32) | k as u64),
        );
        self.by_cell.par_sort_unstable();
        let index = |key: u64| (key & u64::from(u32::MAX)) as usize;
        self.sorted.clear();
        self.sorted
            .extend(self.by_cell.iter().map(|&key| self.tries[index(key)]));
        self.sorted_refused.clear();
        self.sorted_refused.resize(self.sorted.len(), false);
        self.sorted
            .par_chunks(TRIES_PER_TASK)
            .zip(self.sorted_refused.par_chunks_mut(TRIES_PER_TASK))
            .for_each(|(tries, refused)| placer.refusals(tries, radius, refused));
        self.refused.clear();
        self.refused.resize(self.tries.len(), false);
        for (&key, &refused) in self.by_cell.iter().zip(&self.sorted_refused) {
            self.refused[index(key)] = refused;
        }
    }
}

/// Lattice sites from the region's min corner (less a radius), x fastest, each kept if it
/// overlaps nothing.
fn place_lattice<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    rng: &mut Pcg64,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
) -> Result<(), SceneError> {
    let (count, radius) = (fill.count, fill.radius);
    let lo = fill.region.min + V::from_slice(&[radius; 3]);
    let span = fill.region.extent() - V::from_slice(&[2.0 * radius; 3]);
    let start = out.len();
    // A hair more than a diameter apart, so neighbours do not count as touching.
    let spacing = 2.0 * radius * (1.0 + 1e-9);
    let mut per_axis = [1usize; 3];
    for (a, n) in per_axis.iter_mut().enumerate().take(V::DIM) {
        *n = (span.get(a) / spacing).floor() as usize + 1;
    }
    let mut site = [0usize; 3];
    while ((out.len() - start) as u64) < count {
        if site[V::DIM - 1] >= per_axis[V::DIM - 1] {
            return Err(ctx.err(
                format!("fill[{i}].count"),
                format!(
                    "the lattice holds only {} of {count} particles in the region",
                    out.len() - start
                ),
            ));
        }
        let mut c = [0.0; 3];
        for a in 0..V::DIM {
            c[a] = lo.get(a) + spacing * site[a] as f64;
        }
        // next site, x fastest
        for a in 0..V::DIM {
            site[a] += 1;
            if site[a] < per_axis[a] || a == V::DIM - 1 {
                break;
            }
            site[a] = 0;
        }
        let x = placer.wrap(V::from_slice(&c));
        if placer.overlaps(x, radius, 0) {
            continue;
        }
        let v = fill.velocity(rng);
        placer.place(ctx, i, out, (x, v, radius, fill.mass))?;
    }
    Ok(())
}

const GIB: f64 = (1u64 << 30) as f64;

/// A uniformly random unit vector.
fn random_direction<V: Vector>(rng: &mut Pcg64) -> V {
    use std::f64::consts::TAU;
    if V::DIM == 2 {
        let angle = TAU * rng.random::<f64>();
        V::from_slice(&[angle.cos(), angle.sin()])
    } else {
        let z = 2.0 * rng.random::<f64>() - 1.0;
        let angle = TAU * rng.random::<f64>();
        let s = (1.0 - z * z).max(0.0).sqrt();
        V::from_slice(&[s * angle.cos(), s * angle.sin(), z])
    }
}

/// Placement-time overlap checks on a dense grid of linked lists: a head per cell (4 bytes)
/// and, per placed particle, its centre and radius beside the next particle of its cell. A
/// random candidate lands anywhere in a box of millions, so the cells and particles it looks
/// at are cache misses: keeping the centre and radius beside the link (instead of looking
/// them up in the scene's separate position and radius arrays) makes that one miss per
/// particle instead of three. Cells are at least one largest diameter wide, so every particle
/// that can touch a new one is in the 3^D cells around it.
struct PlacementGrid<V> {
    origin: [f64; 3],
    inverse_cell: f64,
    max_radius: f64,
    dims: [usize; 3],
    head: Vec<u32>,
    placed: Vec<Placed<V>>,
    /// One bit per cell: set for the cell of every particle placed since `marks_from`.
    marks: Vec<u64>,
    /// The cells whose bits are set.
    marked: Vec<u32>,
    /// Every particle of this id or above sits in a marked cell.
    marks_from: u32,
}

/// One placed particle in a [`PlacementGrid`].
#[derive(Clone, Copy)]
struct Placed<V> {
    centre: V,
    radius: f64,
    /// The particle placed before it in the same cell, or [`EMPTY`].
    next: u32,
}

const EMPTY: u32 = u32::MAX;

/// Hints the processor to bring the cache line of `value` in; no effect on any result.
#[inline]
fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch is a hint: it never faults and reads nothing the program sees,
        // and the address is a live reference besides.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

impl<V: Vector> PlacementGrid<V> {
    /// A grid over `bounds` for `capacity` particles of radius at most `max_radius`.
    fn new(bounds: Aabb<V>, max_radius: f64, capacity: usize) -> Self {
        let mut cell = 2.0 * max_radius;
        let extent: Vec<f64> = (0..V::DIM)
            .map(|a| bounds.max.get(a) - bounds.min.get(a))
            .collect();
        // Never more than ~4 cells per particle: coarser cells stay correct, just slower.
        let limit = (4 * capacity + 1024) as f64;
        let count = |cell: f64| {
            extent
                .iter()
                .map(|e| (e / cell).floor() + 1.0)
                .product::<f64>()
        };
        if count(cell) > limit {
            cell *= (count(cell) / limit).powf(1.0 / V::DIM as f64) * 1.01;
            while count(cell) > limit {
                cell *= 1.1;
            }
        }
        let mut dims = [1usize; 3];
        let mut origin = [0.0; 3];
        for a in 0..V::DIM {
            dims[a] = (extent[a] / cell).floor() as usize + 1;
            origin[a] = bounds.min.get(a);
        }
        Self {
            origin,
            inverse_cell: 1.0 / cell,
            max_radius,
            dims,
            head: vec![EMPTY; dims.iter().product()],
            placed: Vec::with_capacity(capacity),
            marks: vec![0; dims.iter().product::<usize>().div_ceil(64)],
            marked: Vec::new(),
            marks_from: 0,
        }
    }

    fn coords(&self, x: V) -> [usize; 3] {
        let mut c = [0usize; 3];
        for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
            *slot = self.axis_cell(a, x.get(a));
        }
        c
    }

    fn linear(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Adds particle `id` at `centre` (ids must arrive in order 0, 1, 2, ...).
    fn insert(&mut self, centre: V, radius: f64, id: u32) {
        debug_assert_eq!(id as usize, self.placed.len());
        let cell = self.linear(self.coords(centre));
        self.placed.push(Placed {
            centre,
            radius,
            next: self.head[cell],
        });
        self.head[cell] = id;
        let (word, bit) = (cell / 64, 1u64 << (cell % 64));
        if self.marks[word] & bit == 0 {
            self.marks[word] |= bit;
            self.marked.push(cell as u32);
        }
    }

    /// Clears the marks: from now on, only the cells of particles placed after this call are
    /// marked, so a check for those alone ([`PlacementGrid::overlaps`] with `since` the
    /// particle count now) reads a bit per cell instead of each cell's head.
    fn forget_marks(&mut self) {
        for cell in self.marked.drain(..) {
            self.marks[cell as usize / 64] &= !(1u64 << (cell % 64));
        }
        self.marks_from = self.placed.len() as u32;
    }

    fn is_marked(&self, cell: usize) -> bool {
        self.marks[cell / 64] & (1u64 << (cell % 64)) != 0
    }

    /// The cell holding `coordinate` on `axis`, clamped to the grid: `floor` of the scaled
    /// coordinate, as truncation (the same for `t >= 0`; anything below clamps to 0, and a
    /// NaN, which `as` turns into 0, too) so the hot loop makes no libm call.
    fn axis_cell(&self, axis: usize, coordinate: f64) -> usize {
        let t = (coordinate - self.origin[axis]) * self.inverse_cell;
        (t as i64).clamp(0, self.dims[axis] as i64 - 1) as usize
    }

    /// [`PlacementGrid::overlaps`] for `x` and its images across the seams of `periodic`
    /// (`domain`'s periodic axes) that lie within reach of another particle: `x` is wrapped,
    /// so an image one period away can only touch particles near the opposite face.
    fn overlaps_across(
        &self,
        periodic: &Periodic,
        domain: &Aabb<V>,
        x: V,
        radius: f64,
        since: u32,
    ) -> bool {
        let reach = radius + self.max_radius;
        // Per axis: no shift, and one period towards the far face when x is near a face.
        let mut shifts = [[0.0; 2]; 3];
        let mut count = [1usize; 3];
        for a in (0..V::DIM).filter(|&a| periodic.is_periodic(a)) {
            let (c, length) = (x.get(a), periodic.length(a));
            let widened = carom_engine::grid::widened_reach(c.abs() + length, reach);
            if c - domain.min.get(a) < widened {
                shifts[a][1] = length;
                count[a] = 2;
            } else if domain.max.get(a) - c < widened {
                shifts[a][1] = -length;
                count[a] = 2;
            }
        }
        for z in &shifts[2][..count[2]] {
            for y in &shifts[1][..count[1]] {
                for sx in &shifts[0][..count[0]] {
                    let image = x + V::from_slice(&[*sx, *y, *z]);
                    if self.overlaps(image, radius, since) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The first and last cell per axis that can hold a particle touching one of `radius` at
    /// `x`: within reach, widened past rounding (see carom_engine::grid). Reach is at most a
    /// cell, so at most 4 cells per axis.
    fn cell_range(&self, x: V, radius: f64) -> ([usize; 3], [usize; 3]) {
        let reach = radius + self.max_radius;
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for a in 0..V::DIM {
            let c = x.get(a);
            let widened = carom_engine::grid::widened_reach(c, reach);
            lo[a] = self.axis_cell(a, c - widened);
            hi[a] = self.axis_cell(a, c + widened);
        }
        (lo, hi)
    }

    /// [`PlacementGrid::overlaps`] (with `since` 0) of each of `tries`, [`TRIES_IN_STEP`] at
    /// a time in stages: the same answers, with the misses of several tries overlapping.
    fn refusals(&self, tries: &[V], radius: f64, refused: &mut [bool]) {
        type Range = ([usize; 3], [usize; 3]);
        for (tries, refused) in tries
            .chunks(TRIES_IN_STEP)
            .zip(refused.chunks_mut(TRIES_IN_STEP))
        {
            let mut ranges: [Range; TRIES_IN_STEP] = [([0; 3], [0; 3]); TRIES_IN_STEP];
            for (&x, range) in tries.iter().zip(&mut ranges) {
                *range = self.cell_range(x, radius);
                let (lo, hi) = *range;
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        prefetch(&self.head[self.linear([lo[0], y, z])]);
                    }
                }
            }
            for &(lo, hi) in &ranges[..tries.len()] {
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        let row = self.linear([0, y, z]);
                        for &head in &self.head[row + lo[0]..=row + hi[0]] {
                            if let Some(first) = self.placed.get(head as usize) {
                                prefetch(first);
                            }
                        }
                    }
                }
            }
            for (&x, refused) in tries.iter().zip(refused.iter_mut()) {
                *refused = self.overlaps(x, radius, 0);
            }
        }
    }

    /// True when a particle of `radius` at `x` would overlap one already placed, of id
    /// `since` or above (0: any).
    fn overlaps(&self, x: V, radius: f64, since: u32) -> bool {
        let (lo, hi) = self.cell_range(x, radius);
        // Every cell's head first, then the chains: the heads are independent loads, each
        // likely a cache miss, and the processor fetches them together instead of one after
        // another. (Whether any placed particle overlaps does not depend on the order.)
        // (the particles of `since` or above lie in marked cells: the others need no look)
        let unmarked_are_older = since >= self.marks_from;
        let mut heads = [EMPTY; 64];
        let mut count = 0;
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = self.linear([0, y, z]);
                for cell in row + lo[0]..=row + hi[0] {
                    if unmarked_are_older && !self.is_marked(cell) {
                        continue;
                    }
                    let head = self.head[cell];
                    if count < heads.len() {
                        heads[count] = head;
                        count += 1;
                    } else if self.chain_overlaps(head, x, radius, since) {
                        return true;
                    }
                }
            }
        }
        heads[..count]
            .iter()
            .any(|&head| self.chain_overlaps(head, x, radius, since))
    }

    /// True when a particle of the cell list starting at `head`, of id `since` or above,
    /// overlaps one of `radius` at `x`.
    #[inline]
    fn chain_overlaps(&self, head: u32, x: V, radius: f64, since: u32) -> bool {
        // (a cell's list runs from its latest particle to its first: ids fall along it)
        let mut j = head;
        while j != EMPTY && j >= since {
            let other = &self.placed[j as usize];
            let reach = radius + other.radius;
            if (other.centre - x).length_squared() < reach * reach {
                return true;
            }
            j = other.next;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use rand::SeedableRng;

    /// `count` particles placed at random in the box (-half, half)^D, `batch` tries at a time,
    /// with the given radius mix (every third particle of a second fill twice as large), across
    /// periodic seams when `periodic`.
    fn placed<V: Vector>(batch: usize, count: u64, half: f64, periodic: bool) -> Particles<V> {
        let ctx = Ctx { origin: "test" };
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
            place_random_in_batches(&ctx, i, &fill, &mut rng, &mut placer, &mut out, batch)
                .unwrap();
        }
        out
    }

    /// The particles placed are those of one try after another (a batch of one), whatever the
    /// batch: the batches only change how the tries are checked.
    #[test]
    fn batches_place_the_same_particles_as_one_try_at_a_time() {
        fn same<V: Vector>(count: u64, half: f64, periodic: bool) {
            let one = placed::<V>(1, count, half, periodic);
            assert_eq!(one.len(), 2 * count as usize);
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
}
