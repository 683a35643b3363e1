//! Checkpoints: the complete state of a run, so that `carom resume` continues bit for bit.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! b"CAROMCKP"            magic
//! u32                    format version (FORMAT_VERSION)
//! u32                    dimensions (2 or 3)
//! u64                    steps taken
//! u64                    particle count n
//! u64 + bytes            the scene's TOML text
//! u64 + bytes            the scene's origin (file name or preset)
//! u64 + bytes            run settings (JSON: total steps, broad phase, cells)
//! n x u32                storage order (ids by slot)
//! n x dim x f64          positions, by id
//! n x dim x f64          velocities, by id
//! n x f64                radii, by id
//! n x f64                masses, by id
//! u64 + m x (u32, u32, f64)   resting pair impulses (id a < id b, impulse), sorted
//! u64 + m x (u32, u32, f64)   resting plane impulses (id, plane, impulse), sorted
//! u64 + r x f64          rest times (time units) by id, r = 0 (none has rested) or n
//! u64, u64, 3 x f64      the observables' running sums: 1 when observing (else 0),
//!                        collisions, then virial, thermal integral and interval since the
//!                        last reading (version 4 on; version 3 files read as not observing)
//! u64                    FNV-1a 64 of everything above
//! ```
//!
//! Reading checks the magic, the version, every length against what is left of the file and the
//! checksum, so a damaged or foreign file is refused with a clear message and never makes the
//! reader allocate more than the file holds.

use carom_engine::{ContactImpulses, EngineError, Particles, Tally, Vector, World};
use std::io::{self, Write};

/// Bumped whenever the layout or the meaning of a field changes.
pub const FORMAT_VERSION: u32 = 4;

/// The oldest version this reader still reads (without the observables' sums).
const OLDEST_VERSION: u32 = 3;

const MAGIC: &[u8; 8] = b"CAROMCKP";

/// Why a checkpoint was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckpointError {
    /// Not a checkpoint at all.
    #[error("not a carom checkpoint (bad magic bytes)")]
    NotACheckpoint,
    /// A checkpoint of a format this carom does not read.
    #[error(
        "checkpoint format version {0}, but this carom reads version {FORMAT_VERSION}; \
         resume it with the carom that wrote it"
    )]
    Version(u32),
    /// A checkpoint cut short or changed after it was written.
    #[error("damaged checkpoint: {0}")]
    Damaged(#[from] Damage),
}

/// What is wrong with a damaged checkpoint.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Damage {
    /// Shorter than magic, version and checksum.
    #[error("truncated header")]
    TruncatedHeader,
    /// The bytes do not match their checksum.
    #[error("checksum mismatch")]
    Checksum,
    /// Neither 2 nor 3 dimensions.
    #[error("{0} dimensions")]
    Dimensions(u32),
    /// A particle count whose data could not be addressed.
    #[error("particle count")]
    ParticleCount,
    /// Less particle data than the count needs.
    #[error("{found} bytes of particle data, expected {expected}")]
    ParticleData {
        /// Bytes left in the file.
        found: usize,
        /// Bytes the particle count needs.
        expected: usize,
    },
    /// More impulses than the file holds.
    #[error("impulse count")]
    ImpulseCount,
    /// Rest times for some particles but not all.
    #[error("{count} rest times for {particles} particles")]
    RestTimes {
        /// Rest times stored.
        count: usize,
        /// Particles stored.
        particles: usize,
    },
    /// An observing flag other than 0 or 1.
    #[error("observing flag {0}")]
    ObservingFlag(u64),
    /// Bytes after the last field.
    #[error("{0} bytes left over")]
    LeftOver(usize),
    /// A field cut short.
    #[error("truncated")]
    Truncated,
    /// A text field cut short.
    #[error("truncated text")]
    TruncatedText,
    /// A text field that is not UTF-8.
    #[error("text is not UTF-8")]
    NotUtf8,
}

/// Everything needed to continue a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// 2 or 3.
    pub dimensions: u32,
    /// Steps already taken.
    pub steps_taken: u64,
    /// The scene file's text (parameters, planes; its particles are replaced by the ones here).
    pub scene_toml: String,
    /// Where the scene came from, for messages.
    pub origin: String,
    /// Run settings as JSON (total steps, broad phase override, cells override).
    pub settings_json: String,
    /// Ids by storage slot.
    pub storage_order: Vec<u32>,
    /// Positions by id, `dimensions` values each.
    pub positions: Vec<f64>,
    /// Velocities by id, `dimensions` values each.
    pub velocities: Vec<f64>,
    /// Radii by id.
    pub radii: Vec<f64>,
    /// Masses by id.
    pub masses: Vec<f64>,
    /// The solver's remembered impulses of resting particle pairs, `(a, b, impulse)`.
    pub pair_impulses: Vec<(u32, u32, f64)>,
    /// The same for particles on planes, `(id, plane, impulse)`.
    pub plane_impulses: Vec<(u32, u32, f64)>,
    /// How long each particle has rested (the solver's sleep timers), by id; empty when none
    /// has.
    pub rest: Vec<f64>,
    /// The observables' running sums (see `carom_engine::observe`).
    pub tally: Tally,
}

struct Hashing<W> {
    inner: W,
    hash: u64,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash = fnv(self.hash, &buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// FNV-1a 64's offset basis: the hash of no bytes.
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a 64 of `bytes`, continuing from the hash `h` of the bytes before them.
fn fnv(h: u64, bytes: &[u8]) -> u64 {
    let mut hasher = fnv::FnvHasher::with_key(h);
    std::hash::Hasher::write(&mut hasher, bytes);
    std::hash::Hasher::finish(&hasher)
}

impl Checkpoint {
    /// The complete state of `world` (particles in id order, storage order, remembered
    /// impulses, observable sums) with the scene text, its origin and the run's settings as
    /// JSON: what `carom run` and the Python module both write.
    pub fn of_world<V: Vector>(
        world: &World<V>,
        scene_toml: String,
        origin: String,
        settings_json: String,
    ) -> Self {
        let n = world.len();
        let impulses = world.contact_impulses();
        let mut cp = Checkpoint {
            dimensions: V::DIM as u32,
            steps_taken: world.steps_taken(),
            scene_toml,
            origin,
            settings_json,
            storage_order: world.storage_order().to_vec(),
            positions: Vec::with_capacity(n * V::DIM),
            velocities: Vec::with_capacity(n * V::DIM),
            radii: Vec::with_capacity(n),
            masses: Vec::with_capacity(n),
            pair_impulses: impulses.pairs,
            plane_impulses: impulses.planes,
            rest: impulses.rest,
            tally: world.tally(),
        };
        for id in 0..n {
            let (x, v, r, m) = world.particle(id);
            cp.positions.extend((0..V::DIM).map(|a| x.get(a)));
            cp.velocities.extend((0..V::DIM).map(|a| v.get(a)));
            cp.radii.push(r);
            cp.masses.push(m);
        }
        cp
    }

    /// The remembered impulses, for [`World`]'s resumed builder.
    pub fn contact_impulses(&self) -> ContactImpulses {
        ContactImpulses {
            pairs: self.pair_impulses.clone(),
            planes: self.plane_impulses.clone(),
            rest: self.rest.clone(),
        }
    }

    /// The particles the checkpoint holds, by id, for a world of `V` (the caller checks that
    /// [`Checkpoint::dimensions`] is `V`'s). An error names the first particle the engine
    /// refuses.
    pub fn particles<V: Vector>(&self) -> Result<Particles<V>, EngineError> {
        let d = V::DIM;
        let mut particles = Particles::new();
        for id in 0..self.radii.len() {
            particles.push(
                V::from_slice(&self.positions[id * d..id * d + d]),
                V::from_slice(&self.velocities[id * d..id * d + d]),
                self.radii[id],
                self.masses[id],
            )?;
        }
        Ok(particles)
    }

    /// Writes the checkpoint.
    pub fn write_to(&self, out: &mut dyn Write) -> io::Result<()> {
        let mut w = Hashing {
            inner: &mut *out,
            hash: FNV_OFFSET,
        };
        w.write_all(MAGIC)?;
        w.write_all(&FORMAT_VERSION.to_le_bytes())?;
        w.write_all(&self.dimensions.to_le_bytes())?;
        w.write_all(&self.steps_taken.to_le_bytes())?;
        w.write_all(&(self.radii.len() as u64).to_le_bytes())?;
        for text in [&self.scene_toml, &self.origin, &self.settings_json] {
            w.write_all(&(text.len() as u64).to_le_bytes())?;
            w.write_all(text.as_bytes())?;
        }
        for id in &self.storage_order {
            w.write_all(&id.to_le_bytes())?;
        }
        for array in [&self.positions, &self.velocities, &self.radii, &self.masses] {
            for x in array.iter() {
                w.write_all(&x.to_le_bytes())?;
            }
        }
        for list in [&self.pair_impulses, &self.plane_impulses] {
            w.write_all(&(list.len() as u64).to_le_bytes())?;
            for &(a, b, impulse) in list.iter() {
                w.write_all(&a.to_le_bytes())?;
                w.write_all(&b.to_le_bytes())?;
                w.write_all(&impulse.to_le_bytes())?;
            }
        }
        w.write_all(&(self.rest.len() as u64).to_le_bytes())?;
        for t in &self.rest {
            w.write_all(&t.to_le_bytes())?;
        }
        let t = &self.tally;
        w.write_all(&(t.observing as u64).to_le_bytes())?;
        w.write_all(&t.collisions.to_le_bytes())?;
        for x in [t.virial, t.thermal, t.interval] {
            w.write_all(&x.to_le_bytes())?;
        }
        let hash = w.hash;
        out.write_all(&hash.to_le_bytes())
    }

    /// Reads and checks a checkpoint.
    pub fn read_from(bytes: &[u8]) -> Result<Self, CheckpointError> {
        let (mut r, version) = Reader::open(bytes)?;
        let dimensions = r.u32()?;
        if dimensions != 2 && dimensions != 3 {
            return Err(Damage::Dimensions(dimensions).into());
        }
        let steps_taken = r.u64()?;
        let n = r.u64()? as usize;
        let scene_toml = r.text()?;
        let origin = r.text()?;
        let settings_json = r.text()?;
        let d = dimensions as usize;
        let need = n
            .checked_mul(4 + 2 * 8 * d + 16)
            .ok_or(Damage::ParticleCount)?;
        if r.left() < need {
            return Err(Damage::ParticleData {
                found: r.left(),
                expected: need,
            }
            .into());
        }
        let storage_order = (0..n).map(|_| r.u32()).collect::<Result<Vec<_>, _>>()?;
        let mut floats = |count: usize| (0..count).map(|_| r.f64()).collect::<Result<Vec<_>, _>>();
        let positions = floats(n * d)?;
        let velocities = floats(n * d)?;
        let radii = floats(n)?;
        let masses = floats(n)?;
        let pair_impulses = r.impulses()?;
        let plane_impulses = r.impulses()?;
        let rest = r.rest_times(n)?;
        let tally = r.tally(version)?;
        if r.left() != 0 {
            return Err(Damage::LeftOver(r.left()).into());
        }
        Ok(Self {
            dimensions,
            steps_taken,
            scene_toml,
            origin,
            settings_json,
            storage_order,
            positions,
            velocities,
            radii,
            masses,
            pair_impulses,
            plane_impulses,
            rest,
            tally,
        })
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Checks the magic bytes, the version and the checksum; returns a reader of the body
    /// just after the version, and the version.
    fn open(bytes: &'a [u8]) -> Result<(Self, u32), CheckpointError> {
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(CheckpointError::NotACheckpoint);
        }
        if bytes.len() < 16 {
            return Err(Damage::TruncatedHeader.into());
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let stored = u64::from_le_bytes(tail.try_into().expect("8 bytes"));
        let mut r = Reader { bytes: body, at: 8 };
        let version = r.u32()?;
        if !(OLDEST_VERSION..=FORMAT_VERSION).contains(&version) {
            return Err(CheckpointError::Version(version));
        }
        if fnv(FNV_OFFSET, body) != stored {
            return Err(Damage::Checksum.into());
        }
        Ok((r, version))
    }

    fn take(&mut self, n: usize) -> Result<&[u8], Damage> {
        if self.left() < n {
            return Err(Damage::Truncated);
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }
    fn u32(&mut self) -> Result<u32, Damage> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> Result<u64, Damage> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, Damage> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn text(&mut self) -> Result<String, Damage> {
        let len = self.u64()? as usize;
        if len > self.left() {
            return Err(Damage::TruncatedText);
        }
        String::from_utf8(self.take(len)?.to_vec()).map_err(|_| Damage::NotUtf8)
    }

    /// Remembered impulses: a count, then `(a, b, impulse)` each.
    fn impulses(&mut self) -> Result<Vec<(u32, u32, f64)>, Damage> {
        let m = self.u64()? as usize;
        if m.checked_mul(16).is_none_or(|bytes| bytes > self.left()) {
            return Err(Damage::ImpulseCount);
        }
        (0..m)
            .map(|_| Ok((self.u32()?, self.u32()?, self.f64()?)))
            .collect()
    }

    /// Rest times: none, or one for each of the `particles`.
    fn rest_times(&mut self, particles: usize) -> Result<Vec<f64>, Damage> {
        let count = self.u64()? as usize;
        if count != 0 && count != particles {
            return Err(Damage::RestTimes { count, particles });
        }
        (0..count).map(|_| self.f64()).collect()
    }

    /// The observables' running sums: written from format version 4 on, none before.
    fn tally(&mut self, version: u32) -> Result<Tally, Damage> {
        if version < 4 {
            return Ok(Tally::default());
        }
        Ok(Tally {
            observing: match self.u64()? {
                0 => false,
                1 => true,
                other => return Err(Damage::ObservingFlag(other)),
            },
            collisions: self.u64()?,
            virial: self.f64()?,
            thermal: self.f64()?,
            interval: self.f64()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            dimensions: 2,
            steps_taken: 17,
            scene_toml: "dimensions = 2\ndt = 0.01\n".into(),
            origin: "scene.toml".into(),
            settings_json: "{}".into(),
            storage_order: vec![1, 0],
            positions: vec![0.1, -0.2, 1.0 / 3.0, 5.0],
            velocities: vec![1.0, 2.0, 3.0, -0.0],
            radii: vec![0.5, 0.25],
            masses: vec![1.0, 2.0],
            pair_impulses: vec![(0, 1, 0.75)],
            plane_impulses: vec![(1, 3, 0.125)],
            rest: vec![0.5, 0.0],
            tally: Tally {
                observing: true,
                collisions: 12,
                virial: 0.25,
                thermal: 3.5,
                interval: 0.125,
            },
        }
    }

    #[test]
    fn round_trips_bit_for_bit() {
        let mut bytes = Vec::new();
        sample().write_to(&mut bytes).unwrap();
        let back = Checkpoint::read_from(&bytes).unwrap();
        assert_eq!(back, sample());
        assert_eq!(back.velocities[3].to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn version_3_files_still_read_with_the_observables_at_zero() {
        let old = Checkpoint {
            tally: Tally::default(),
            ..sample()
        };
        let mut bytes = Vec::new();
        old.write_to(&mut bytes).unwrap();
        // a version 3 file: no observables' sums (40 bytes) before the checksum
        let mut body = bytes[..bytes.len() - 8 - 40].to_vec();
        body[8..12].copy_from_slice(&3u32.to_le_bytes());
        let hash = fnv(FNV_OFFSET, &body);
        body.extend_from_slice(&hash.to_le_bytes());
        assert_eq!(Checkpoint::read_from(&body).unwrap(), old);
    }

    #[test]
    fn damage_and_foreign_files_are_refused() {
        let mut bytes = Vec::new();
        sample().write_to(&mut bytes).unwrap();
        for i in [0, 9, 20, 40, bytes.len() / 2, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[i] ^= 0x40;
            assert!(Checkpoint::read_from(&bad).is_err(), "flipped byte {i}");
        }
        for cut in [0, 7, 12, 30, bytes.len() - 9, bytes.len() - 1] {
            assert!(
                Checkpoint::read_from(&bytes[..cut]).is_err(),
                "cut at {cut}"
            );
        }
        let mut other = bytes.clone();
        other[8..12].copy_from_slice(&99u32.to_le_bytes());
        let e = Checkpoint::read_from(&other).unwrap_err();
        assert_eq!(e, CheckpointError::Version(99));
        assert!(e.to_string().contains("version 99"), "{e}");
        let e = Checkpoint::read_from(b"id,x,y\n1,2,3\n").unwrap_err();
        assert_eq!(e, CheckpointError::NotACheckpoint);
        assert!(e.to_string().contains("not a carom checkpoint"));
        let mut cut = bytes.clone();
        cut.truncate(12);
        assert_eq!(
            Checkpoint::read_from(&cut).unwrap_err().to_string(),
            "damaged checkpoint: truncated header"
        );
    }
}
