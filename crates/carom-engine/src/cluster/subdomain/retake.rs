//! One rank's part in taking a step again (see `solver::escape`).

use crate::cluster::traffic::{Link, TrafficKind};
use crate::cluster::transport::Transport;
use crate::cluster::wire::{Reader, Writer};
use crate::solver::{self, Moved};
use crate::vector::Vector;

use super::*;

impl<V: Vector> Subdomain<V> {
    /// As a world's `take_back_escapes`: every rank's escapees go to every rank, each counts
    /// the strikes on its own particles, and when any rank counted one, every rank puts its
    /// own particles back where its search found them (the start of the step) and notes its
    /// escapees' moves for the next try.
    pub(super) fn take_back_escapes<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        tries: u32,
    ) -> bool {
        let settings = self.config.solver_settings();
        let covers = solver::reach_covers_pushes(&settings, &self.planes);
        // (every rank decides this alike: the gather below is collective)
        if tries > settings.retakes || !covers {
            return false;
        }
        debug_assert_eq!(
            self.reach.len(),
            self.own,
            "the search gave every own slot a reach"
        );
        let (own, search, window) = (self.own, &self.search, &self.window);
        let (reach, ids) = (&self.reach, &self.ids);
        // (the search's own particles come first, in slot order, as the step found them)
        let particle = |s: usize| Moved {
            id: ids[s],
            start: search.position[s],
            end: window.position[s],
            radius: window.radius[s],
            reach: reach[s],
        };
        let parallel = own >= crate::broadphase::PARALLEL_MIN;
        let retakes = &mut self.retakes;
        retakes.collect(own, parallel, particle);
        let mut mine = Writer::default();
        for e in &retakes.escapes.list {
            mine.u32(e.id)
                .vector(e.start)
                .vector(e.end)
                .f64(e.radius)
                .f64(e.reach);
        }
        let every = link.gather(TrafficKind::Ghosts, &mine.0);
        // (this rank's own escapees stay first, in slot order, for `take_again`)
        let list = &mut retakes.escapes.list;
        for (rank, bytes) in every.iter().enumerate() {
            if rank == self.rank {
                continue;
            }
            let mut r = Reader::new(bytes);
            while !r.is_empty() {
                let (id, start, end) = (r.u32(), r.vector(), r.vector());
                let (radius, reach) = (r.f64(), r.f64());
                list.push(Moved {
                    id,
                    start,
                    end,
                    radius,
                    reach,
                });
            }
        }
        if list.is_empty() {
            return false;
        }
        retakes.escapes.index(self.max_radius, own, None);
        let strikes = retakes
            .escapes
            .strikes(&window.position[..own], parallel, particle);
        if link.sum(&[strikes])[0] == 0 {
            return false;
        }
        retakes.take_again(own);
        let window = &mut self.window;
        window.position[..own].copy_from_slice(&search.position[..own]);
        window.velocity[..own].copy_from_slice(&search.velocity[..own]);
        true
    }
}
