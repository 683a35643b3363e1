//! What the walls of `[domain] walls = true` can hold: every explicit particle wholly inside
//! them, and every `[[fill]]` region too. The engine would push a particle found outside back
//! in on the first step (and one wider than the box out of it), so such a scene is refused
//! here, naming the field, as every other bad scene is.

use crate::{Ctx, SceneError};
use carom_engine::{Aabb, Vector};

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
                        "{} = {c} puts the particle (radius {r}) outside the walls: its centre \
                         must lie in [{lo}, {hi}] (the domain [{}, {}] less the radius)",
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
                    "{} = {value} is outside the walls (the domain's {side} is {limit} there): \
                     a fill region must lie inside them",
                    AXES[a]
                ),
            ));
        }
        Ok(())
    }
}
