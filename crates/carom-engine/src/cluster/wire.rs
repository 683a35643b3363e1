//! Little-endian encoding of the values ranks send each other.

use crate::vector::Vector;

/// Appends values to a message.
#[derive(Default)]
pub(crate) struct Writer(pub Vec<u8>);

impl Writer {
    pub fn u32(&mut self, x: u32) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    pub fn u64(&mut self, x: u64) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    pub fn f64(&mut self, x: f64) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    pub fn vector<V: Vector>(&mut self, x: V) -> &mut Self {
        for a in 0..V::DIM {
            self.f64(x.get(a));
        }
        self
    }
}

/// Reads values back in the order they were written. Messages come from other ranks of the
/// same program, so a short message is a bug, not bad input: it panics.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let (head, rest) = self.bytes.split_at(N);
        self.bytes = rest;
        head.try_into().expect("split_at gave N bytes")
    }
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    pub fn vector<V: Vector>(&mut self) -> V {
        let mut c = [0.0; 3];
        for x in c.iter_mut().take(V::DIM) {
            *x = self.f64();
        }
        V::from_slice(&c)
    }
}
