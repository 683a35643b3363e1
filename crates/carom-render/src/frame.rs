//! [`Frame`]: a plain snapshot of a world, independent of the engine's vector type.

use carom_engine::{Vector, World};

/// An axis-aligned box (in 2D the third components are ignored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Lowest corner.
    pub min: [f64; 3],
    /// Highest corner.
    pub max: [f64; 3],
}

impl Bounds {
    /// The smallest box holding both.
    pub fn union(self, other: Bounds) -> Bounds {
        let mut b = self;
        for a in 0..3 {
            b.min[a] = b.min[a].min(other.min[a]);
            b.max[a] = b.max[a].max(other.max[a]);
        }
        b
    }

    /// The centre.
    pub fn centre(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| 0.5 * (self.min[a] + self.max[a]))
    }
}

/// A plane: a point on it and its normal (pointing into the allowed side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePlane {
    /// Any point on the plane.
    pub point: [f64; 3],
    /// The unit normal.
    pub normal: [f64; 3],
}

/// One moment of a simulation, ready to draw: particles in id order, 2D vectors stored with
/// a zero third component.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// 2 or 3.
    pub dimensions: usize,
    /// Particle centres, by id.
    pub positions: Vec<[f64; 3]>,
    /// Particle velocities, by id.
    pub velocities: Vec<[f64; 3]>,
    /// Particle radii, by id.
    pub radii: Vec<f64>,
    /// Every plane, domain walls included.
    pub planes: Vec<FramePlane>,
    /// The simulation space, if the scene has one.
    pub domain: Option<Bounds>,
    /// Steps taken.
    pub step: u64,
    /// Simulated time.
    pub time: f64,
}

fn components<V: Vector>(v: V) -> [f64; 3] {
    let mut c = [0.0; 3];
    for (a, x) in c.iter_mut().enumerate().take(V::DIM) {
        *x = v.get(a);
    }
    c
}

impl Frame {
    /// An empty frame of `dimensions` (2 or 3) at step 0.
    pub fn new(dimensions: usize) -> Self {
        Self {
            dimensions,
            positions: Vec::new(),
            velocities: Vec::new(),
            radii: Vec::new(),
            planes: Vec::new(),
            domain: None,
            step: 0,
            time: 0.0,
        }
    }

    /// Adds a particle (the next id).
    pub fn push(&mut self, position: [f64; 3], velocity: [f64; 3], radius: f64) {
        self.positions.push(position);
        self.velocities.push(velocity);
        self.radii.push(radius);
    }

    /// A snapshot of `world`: its particles in id order, its planes (walls included), its
    /// domain, steps taken and time.
    pub fn from_world<V: Vector>(world: &World<V>) -> Self {
        let particles = world.particles();
        Self {
            dimensions: V::DIM,
            positions: particles
                .positions()
                .iter()
                .map(|&x| components(x))
                .collect(),
            velocities: particles
                .velocities()
                .iter()
                .map(|&v| components(v))
                .collect(),
            radii: particles.radii().to_vec(),
            planes: world
                .planes()
                .iter()
                .map(|p| FramePlane {
                    point: components(p.point()),
                    normal: components(p.normal()),
                })
                .collect(),
            domain: world.config().domain.map(|d| Bounds {
                min: components(d.min),
                max: components(d.max),
            }),
            step: world.steps_taken(),
            time: world.time(),
        }
    }

    /// The particles' bounding box, radii included; `None` without particles.
    pub fn particle_bounds(&self) -> Option<Bounds> {
        let mut b: Option<Bounds> = None;
        for (x, &r) in self.positions.iter().zip(&self.radii) {
            if !x.iter().all(|c| c.is_finite()) || !r.is_finite() {
                continue;
            }
            let p = Bounds {
                min: [0, 1, 2].map(|a| x[a] - r),
                max: [0, 1, 2].map(|a| x[a] + r),
            };
            b = Some(b.map_or(p, |b| b.union(p)));
        }
        b
    }

    /// What the view fits by default: the domain, else the particles' bounding box, else a
    /// unit box around the origin.
    pub fn view_bounds(&self) -> Bounds {
        self.domain
            .or_else(|| self.particle_bounds())
            .unwrap_or(Bounds {
                min: [-1.0; 3],
                max: [1.0; 3],
            })
    }
}
