//! The particle set of a scene: explicit `[[particles]]`, then each `[[fill]]` placed without
//! overlap (random, seeded; or on a lattice).

use crate::placement::PlacementGrid;
use crate::raw::{RawArrangement, RawFill, RawScene};
use crate::screen::Screen;
use crate::walls::Walled;
use crate::{Ctx, SceneError};
use carom_engine::{Aabb, Particles, Periodic, Vector};
use draws::{draw_tries, VELOCITY_STREAM_OFFSET};
use rand::SeedableRng;
use rand_pcg::Pcg64;

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
        total,
    };
    placer.grid.add(
        out.positions()
            .iter()
            .copied()
            .zip(out.radii().iter().copied()),
    );
    for (i, f) in raw.fill.iter().enumerate() {
        fill_one(ctx, i, f, regions[i], &mut placer, &mut out)?;
    }
    (ctx.progress)(out.len() as u64, total);
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
pub(crate) struct Placer<V> {
    pub grid: PlacementGrid<V>,
    seams: Option<(Periodic, Aabb<V>)>,
    /// The scene's particles in all, for progress reports.
    total: u64,
}

impl<V: Vector> Placer<V> {
    /// True when a particle of `radius` at `x` would overlap a placed one (see
    /// [`PlacementGrid`]), across the seams too.
    fn overlaps_settled(&self, x: V, radius: f64) -> bool {
        self.across_seams(x, radius, |x| self.grid.overlaps_settled(x, radius))
    }

    /// `test` of `x`, and of its images across the seams when there are any, until one says
    /// true.
    pub fn across_seams(&self, x: V, radius: f64, test: impl FnMut(V) -> bool) -> bool {
        match &self.seams {
            None => {
                let mut test = test;
                test(x)
            }
            Some((p, d)) => self.grid.across_seams(p, d, x, radius, test),
        }
    }

    /// For each of `tries`, whether a particle of `radius` there would overlap a placed one.
    pub fn refusals(&self, tries: impl Iterator<Item = V>, radius: f64, refused: &mut [bool]) {
        for (x, refused) in tries.zip(refused) {
            *refused = self.overlaps_settled(x, radius);
        }
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
        RawArrangement::Random => place_random(ctx, i, &fill, &mut rng, placer, out, batch_size),
        RawArrangement::Lattice => place_lattice(ctx, i, &fill, &mut rng, placer, out, false),
        RawArrangement::Hex => place_lattice(ctx, i, &fill, &mut rng, placer, out, true),
    }
}

/// Random tries drawn and checked together (see [`place_random`]): at least this many, or
/// half as many as the particles placed so far (each batch ends by merging its particles into
/// the settled ones, a pass over them all). The particles placed do not depend on it: a batch
/// of 1 places the same ones.
const TRIES_PER_BATCH: usize = 65536;

/// Where a random fill stands when it draws a batch of tries.
#[derive(Clone, Copy, Debug)]
struct SoFar {
    /// Particles placed in the scene so far.
    placed: usize,
    /// Particles of the fill still to place.
    left: u64,
    /// Tries drawn in the last batch and particles it placed (none before the first).
    last: Option<(u64, u64)>,
}

/// Tries in a batch: [`TRIES_PER_BATCH`], or half as many as are placed, up to
/// [`MAX_TRIES_PER_BATCH`], and no more than [`needed_tries`].
fn batch_size(so_far: SoFar) -> usize {
    (so_far.placed / 2)
        .clamp(TRIES_PER_BATCH, MAX_TRIES_PER_BATCH)
        .min(needed_tries(so_far))
}

/// About twice the tries the particles left need, at the last batch's rate of success (four
/// per particle before the first), and at least [`MIN_TRIES_PER_BATCH`]. Each try of a batch
/// that passes the first check is checked against those around it, so a batch far larger
/// than a small fill needs would cost the square of its size in one cell of a coarse grid (a
/// fuzzed scene: 100 discs, 30,000 tries at once, 0.7 s).
fn needed_tries(so_far: SoFar) -> usize {
    let per_particle = match so_far.last {
        None => 4.0,
        Some((_, 0)) => return usize::MAX,
        Some((drawn, placed)) => 2.0 * drawn as f64 / placed as f64,
    };
    (so_far.left as f64 * per_particle).max(MIN_TRIES_PER_BATCH as f64) as usize
}

/// See [`needed_tries`].
const MIN_TRIES_PER_BATCH: usize = 256;

/// The most tries in a batch (each takes 9 D + 26 bytes of [`Screen`]).
const MAX_TRIES_PER_BATCH: usize = 1 << 18;

/// Random positions over the region (less a radius), each kept if it overlaps nothing placed
/// before it: random sequential adsorption, try after try, decided in batches (see
/// [`place_in_batches`]). `batch` says how many tries a batch draws ([`batch_size`]).
fn place_random<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    rng: &mut Pcg64,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
    batch: impl Fn(SoFar) -> usize,
) -> Result<(), SceneError> {
    let (count, radius) = (fill.count, fill.radius);
    let lo = fill.region.min + V::from_slice(&[radius; 3]);
    let span = fill.region.extent() - V::from_slice(&[2.0 * radius; 3]);
    let start = out.len();
    let budget = ATTEMPTS_PER_PARTICLE * count + 10_000;
    let mut velocities = rng.clone();
    velocities.advance(VELOCITY_STREAM_OFFSET);
    let mut attempts = 0u64;
    let seams = placer.seams;
    let mut last: Option<(u64, usize)> = None;
    let draw = |tries: &mut Vec<V>, placed: usize| {
        let so_far = SoFar {
            placed,
            left: count - (placed - start) as u64,
            last: last.map(|(drawn, before)| (drawn, (placed - before) as u64)),
        };
        let size = (batch(so_far).max(1) as u64).min(budget - attempts);
        last = Some((size, placed));
        attempts += size;
        let wrap = |x: V| seams.map_or(x, |(p, _)| p.wrap(x));
        draw_tries(rng, (lo, span), wrap, size as usize, tries);
    };
    if place_in_batches(ctx, i, fill, placer, out, &mut velocities, draw)? {
        return Ok(());
    }
    Err(ctx.err(
        format!("fill[{i}].count"),
        format!(
            "placed only {} of {count} particles without overlap after {budget} random tries; \
             enlarge the region, lower count or radius, or use arrangement = \"lattice\" or \"hex\"",
            out.len() - start
        ),
    ))
}

/// Places the tries that `draw(tries, particles placed so far)` pushes, batch after batch,
/// until the fill has its count (true) or `draw` pushes none (false). A try is placed exactly
/// when it overlaps nothing placed before it, as one try after another would decide, for any
/// batch size or thread count (see [`Screen`]); each placed try takes the next velocity of
/// `velocities`.
fn place_in_batches<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
    velocities: &mut Pcg64,
    mut draw: impl FnMut(&mut Vec<V>, usize),
) -> Result<bool, SceneError> {
    let (count, radius) = (fill.count, fill.radius);
    let start = out.len();
    let mut screen = Screen::default();
    let mut speeds = Vec::new();
    loop {
        screen.tries.clear();
        draw(&mut screen.tries, out.len());
        if screen.tries.is_empty() {
            return Ok(false);
        }
        screen.decide(placer, radius);
        let left = count - (out.len() - start) as u64;
        let (taken, end) = screen.placed_up_to(left);
        fill.velocities(velocities, taken, &mut speeds);
        for (&x, &v) in screen.placed_tries(end).zip(&speeds) {
            out.push(x, v, radius, fill.mass)
                .map_err(|e| ctx.err(format!("fill[{i}]"), e.to_string()))?;
        }
        screen.settle(&mut placer.grid, end, radius);
        (ctx.progress)(out.len() as u64, placer.total);
        if (out.len() - start) as u64 == count {
            return Ok(true);
        }
    }
}

/// Lattice sites from the region's min corner (less a radius), x fastest, each kept if it
/// overlaps nothing and lies in the region: a square (cubic) lattice, or with `hex` a close
/// packing, rows of a triangular lattice (in 3D, its layers stacked ABAB: hexagonal close
/// packing), every neighbour a hair more than a diameter away.
fn place_lattice<V: Vector>(
    ctx: &Ctx,
    i: usize,
    fill: &Fill<V>,
    rng: &mut Pcg64,
    placer: &mut Placer<V>,
    out: &mut Particles<V>,
    hex: bool,
) -> Result<(), SceneError> {
    let (count, radius) = (fill.count, fill.radius);
    let lo = fill.region.min + V::from_slice(&[radius; 3]);
    let span = fill.region.extent() - V::from_slice(&[2.0 * radius; 3]);
    let start = out.len();
    // A hair more than a diameter apart, so neighbours do not count as touching.
    let spacing = 2.0 * radius * (1.0 + 1e-9);
    // (site steps along each axis: a close packing's rows are sqrt(3)/2 apart, its layers
    // sqrt(2/3))
    let step = if hex {
        [
            spacing,
            spacing * 0.75f64.sqrt(),
            spacing * (2.0f64 / 3.0).sqrt(),
        ]
    } else {
        [spacing; 3]
    };
    let mut per_axis = [1usize; 3];
    for (a, n) in per_axis.iter_mut().enumerate().take(V::DIM) {
        *n = (span.get(a) / step[a]).floor() as usize + 1;
    }
    let seams = placer.seams;
    let mut site = [0usize; 3];
    let most_sites = count
        .saturating_mul(LATTICE_SITES_PER_PARTICLE)
        .max(LATTICE_SITES_AT_LEAST);
    let mut visited = 0u64;
    let draw = |tries: &mut Vec<V>, placed: usize| {
        let left = count - (placed - start) as u64;
        let size = LATTICE_SITES_PER_BATCH.min(left.max(MIN_TRIES_PER_BATCH as u64) as usize);
        while tries.len() < size && site[V::DIM - 1] < per_axis[V::DIM - 1] {
            if visited == most_sites {
                break;
            }
            visited += 1;
            let c = lattice_site(site, step, hex);
            // next site, x fastest
            for a in 0..V::DIM {
                site[a] += 1;
                if site[a] < per_axis[a] || a == V::DIM - 1 {
                    break;
                }
                site[a] = 0;
            }
            // (a close packing's shifted rows may reach past the region by half a site)
            if (0..V::DIM).any(|a| c[a] > span.get(a) * (1.0 + 1e-12)) {
                continue;
            }
            let x = lo + V::from_slice(&c);
            tries.push(seams.map_or(x, |(p, _)| p.wrap(x)));
        }
    };
    if place_in_batches(ctx, i, fill, placer, out, rng, draw)? {
        return Ok(());
    }
    let placed = out.len() - start;
    let message = if visited == most_sites {
        format!(
            "placed only {placed} of {count} particles in the first {most_sites} lattice sites \
             (the rest overlap other particles); move the region or the particles in it"
        )
    } else {
        format!("the lattice holds only {placed} of {count} particles in the region")
    };
    Err(ctx.err(format!("fill[{i}].count"), message))
}

/// The most lattice sites a fill visits: this many a particle, and at least
/// [`LATTICE_SITES_AT_LEAST`]. A fill free of other particles takes about one site a particle;
/// without a bound, a fill of tiny particles behind a large one went through the sites it
/// covers (10^24 of them in a fuzzed scene) and never ended.
const LATTICE_SITES_PER_PARTICLE: u64 = 64;

/// See [`LATTICE_SITES_PER_PARTICLE`]: about a second's sites.
const LATTICE_SITES_AT_LEAST: u64 = 1 << 24;

/// Where lattice site `site` (counted per axis) lies from the first one, sites `step` apart
/// per axis: on a square (cubic) lattice; or, with `hex`, odd rows shifted by half a site
/// along x, and odd layers by half a site along x and a third of a row along y (the hollows of
/// the layer below).
fn lattice_site(site: [usize; 3], step: [f64; 3], hex: bool) -> [f64; 3] {
    let [i, j, k] = site.map(|n| n as f64);
    if !hex {
        return [i * step[0], j * step[1], k * step[2]];
    }
    let (odd_row, odd_layer) = ((site[1] % 2) as f64, (site[2] % 2) as f64);
    [
        (i + 0.5 * odd_row + 0.5 * odd_layer) * step[0],
        (j + odd_layer / 3.0) * step[1],
        k * step[2],
    ]
}

/// Lattice sites decided together (see [`place_in_batches`]), or as many as particles are
/// left to place (at least [`MIN_TRIES_PER_BATCH`]) if fewer: most sites are taken.
const LATTICE_SITES_PER_BATCH: usize = 65536;

const GIB: f64 = (1u64 << 30) as f64;

mod draws;
#[cfg(test)]
mod tests;
