//! What the walls of `[domain] walls = true` and the `[[planes]]` can hold: every explicit
//! particle wholly inside the walls and in front of every plane, and every `[[fill]]` region
//! (and so every particle it places) too. The engine would push a particle found outside back
//! in on the first step (and one wider than the box out of it), so such a scene is refused
//! here, naming the field, as every other bad scene is.

use crate::{Ctx, SceneError};
use carom_engine::{Aabb, Particles, Plane, Vector};

const AXES: [&str; 3] = ["x", "y", "z"];

/// The box the walls close and the axes they close (the domain's axes that are not periodic).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Walled<V> {
    bounds: Aabb<V>,
    axes: [bool; 3],
}

impl<V: Vector> Walled<V> {
    /// The walls of `domain` when `walls` is on, on every axis that does not wrap; `None` when
    /// there are none.
    pub(crate) fn new(domain: Option<Aabb<V>>, walls: bool, periodic: [bool; 3]) -> Option<Self> {
        let bounds = domain.filter(|_| walls)?;
        let mut axes = [false; 3];
        for (a, closed) in axes.iter_mut().enumerate().take(V::DIM) {
            *closed = !periodic[a];
        }
        axes.iter().any(|&a| a).then_some(Self { bounds, axes })
    }

    fn closed(&self) -> impl Iterator<Item = usize> + '_ {
        (0..V::DIM).filter(|&a| self.axes[a])
    }

    /// Explicit particle `i` at `x` with radius `r` must lie wholly inside the walls.
    pub(crate) fn check_particle(
        &self,
        ctx: &Ctx,
        i: usize,
        x: V,
        r: f64,
    ) -> Result<(), SceneError> {
        let (min, max) = (self.bounds.min, self.bounds.max);
        for a in self.closed() {
            let length = max.get(a) - min.get(a);
            if 2.0 * r > length {
                return Err(ctx.err(
                    format!("particles[{i}].radius"),
                    format!(
                        "a particle of radius {r} is wider than the walled box, whose {} side \
                         is {length} long",
                        AXES[a]
                    ),
                ));
            }
        }
        for a in self.closed() {
            let (lo, hi, c) = (min.get(a) + r, max.get(a) - r, x.get(a));
            if !(lo..=hi).contains(&c) {
                return Err(ctx.err(
                    format!("particles[{i}].position"),
                    format!(
                        "{} = {c:?} puts the particle (radius {r:?}) outside the walls: its centre \
                         must lie in [{lo:?}, {hi:?}] (the domain [{:?}, {:?}] less the radius)",
                        AXES[a],
                        min.get(a),
                        max.get(a)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The region of `[[fill]]` `i` must lie inside the walls.
    pub(crate) fn check_region(
        &self,
        ctx: &Ctx,
        i: usize,
        region: &Aabb<V>,
    ) -> Result<(), SceneError> {
        let (min, max) = (self.bounds.min, self.bounds.max);
        for a in self.closed() {
            let (side, value, limit) = if region.min.get(a) < min.get(a) {
                ("min", region.min.get(a), min.get(a))
            } else if region.max.get(a) > max.get(a) {
                ("max", region.max.get(a), max.get(a))
            } else {
                continue;
            };
            return Err(ctx.err(
                format!("fill[{i}].{side}"),
                format!(
                    "{} = {value:?} is outside the walls (the domain's {side} is {limit:?} there): \
                     a fill region must lie inside them",
                    AXES[a]
                ),
            ));
        }
        Ok(())
    }
}

/// Every particle must lie wholly on the allowed side of every `[[planes]]` entry (the side its
/// normal points to): the engine would push one found behind a plane through it on the first
/// step. An explicit particle is named by its position; a fill's particle by its fill (its
/// region reaches past the plane). `fills`: how many particles each fill placed, after the
/// `explicit` ones.
pub(crate) fn check_planes<V: Vector>(
    ctx: &Ctx,
    planes: &[Plane<V>],
    particles: &Particles<V>,
    explicit: usize,
    fills: &[usize],
) -> Result<(), SceneError> {
    if planes.is_empty() {
        return Ok(());
    }
    let owner = |id: usize| -> String {
        if id < explicit {
            return format!("particles[{id}].position");
        }
        let mut start = explicit;
        for (i, &count) in fills.iter().enumerate() {
            if id < start + count {
                return format!("fill[{i}]");
            }
            start += count;
        }
        format!("particles[{id}]")
    };
    let rows = particles.positions().iter().zip(particles.radii());
    for (id, (&x, &r)) in rows.enumerate() {
        for (j, plane) in planes.iter().enumerate() {
            let d = plane.signed_distance(x);
            // a hair of slack for the rounding of the normalised normal
            if d < r * (1.0 - 1e-9) {
                let what = if id < explicit {
                    "the particle"
                } else {
                    "a particle this fill places"
                };
                return Err(ctx.err(
                    owner(id),
                    format!(
                        "{what} (radius {r}) lies {} planes[{j}]: its centre is {d} from the \
                         plane, on the side its normal points to, and must be at least the \
                         radius",
                        if d < 0.0 { "behind" } else { "partly behind" }
                    ),
                ));
            }
        }
    }
    Ok(())
}
