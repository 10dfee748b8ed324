//! The two wire formats of ROS messages, read and written field by field.
//!
//! - ROS 1: little endian, no alignment, strings as `uint32` length and bytes (no NUL).
//! - ROS 2 CDR (XCDR1): a 4-byte encapsulation header (`00 01` little endian, `00 00` big
//!   endian, then two option bytes), then each primitive aligned to its own size counted from
//!   the byte after the header; strings as `uint32` length including a terminating NUL.

use super::error::MessageProblem;

/// The layout rules of a serialized message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flavor {
    /// ROS 1 serialization.
    Ros1,
    /// CDR, little endian.
    CdrLittle,
    /// CDR, big endian.
    CdrBig,
}

impl Flavor {
    fn aligned(self) -> bool {
        self != Flavor::Ros1
    }

    fn big(self) -> bool {
        self == Flavor::CdrBig
    }
}

/// Reads one serialized message, checking every length before it is used.
pub(crate) struct Decoder<'a> {
    data: &'a [u8],
    pos: usize,
    /// Where alignment is counted from (the byte after the CDR header).
    origin: usize,
    flavor: Flavor,
}

impl<'a> Decoder<'a> {
    /// A ROS 1 message.
    pub(crate) fn ros1(data: &'a [u8]) -> Self {
        Decoder {
            data,
            pos: 0,
            origin: 0,
            flavor: Flavor::Ros1,
        }
    }

    /// A CDR message: reads and checks the encapsulation header.
    pub(crate) fn cdr(data: &'a [u8]) -> Result<Self, MessageProblem> {
        let flavor = match data.get(..2) {
            Some([0, 1]) => Flavor::CdrLittle,
            Some([0, 0]) => Flavor::CdrBig,
            Some(&[a, b]) => return Err(MessageProblem::Encapsulation([a, b])),
            _ => {
                return Err(MessageProblem::Truncated {
                    field: "encapsulation header",
                    offset: 0,
                });
            }
        };
        if data.len() < 4 {
            return Err(MessageProblem::Truncated {
                field: "encapsulation header",
                offset: 0,
            });
        }
        Ok(Decoder {
            data,
            pos: 4,
            origin: 4,
            flavor,
        })
    }

    /// The flavor read from the header (or ROS 1).
    pub(crate) fn flavor(&self) -> Flavor {
        self.flavor
    }

    /// Bytes not read yet.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Fails unless the whole message has been read (CDR may end with up to 3 padding bytes).
    pub(crate) fn finish(&self) -> Result<(), MessageProblem> {
        let slack = if self.flavor.aligned() { 3 } else { 0 };
        match self.remaining() {
            n if n <= slack => Ok(()),
            n => Err(MessageProblem::TrailingBytes { bytes: n }),
        }
    }

    fn align(&mut self, n: usize) {
        if self.flavor.aligned() {
            let rel = self.pos - self.origin;
            self.pos += (n - rel % n) % n;
        }
    }

    fn take<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], MessageProblem> {
        self.align(N);
        let bytes = self
            .data
            .get(self.pos..self.pos.saturating_add(N))
            .and_then(|b| <[u8; N]>::try_from(b).ok())
            .ok_or(MessageProblem::Truncated {
                field,
                offset: self.pos.min(self.data.len()),
            })?;
        self.pos += N;
        Ok(bytes)
    }

    pub(crate) fn u32(&mut self, field: &'static str) -> Result<u32, MessageProblem> {
        let b = self.take::<4>(field)?;
        Ok(if self.flavor.big() {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    pub(crate) fn f32(&mut self, field: &'static str) -> Result<f32, MessageProblem> {
        self.u32(field).map(f32::from_bits)
    }

    pub(crate) fn f64(&mut self, field: &'static str) -> Result<f64, MessageProblem> {
        let b = self.take::<8>(field)?;
        Ok(f64::from_bits(if self.flavor.big() {
            u64::from_be_bytes(b)
        } else {
            u64::from_le_bytes(b)
        }))
    }

    /// A string; its length is checked against the bytes left before anything is copied.
    pub(crate) fn string(&mut self, field: &'static str) -> Result<String, MessageProblem> {
        let n = self.count(field, 1)?;
        let start = self.pos;
        let mut bytes = &self.data[start..start + n];
        self.pos += n;
        if self.flavor.aligned() {
            match bytes.split_last() {
                Some((0, rest)) => bytes = rest,
                _ => return Err(MessageProblem::BadString { field }),
            }
        }
        String::from_utf8(bytes.to_vec()).map_err(|_| MessageProblem::BadString { field })
    }

    /// A sequence length whose `element_bytes`-sized elements must all fit in what is left.
    pub(crate) fn count(
        &mut self,
        field: &'static str,
        element_bytes: usize,
    ) -> Result<usize, MessageProblem> {
        let n = self.u32(field)?;
        let fits = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(element_bytes))
            .is_some_and(|bytes| {
                // Elements are aligned to their size: the first may be preceded by padding.
                let pad = if self.flavor.aligned() && n > 0 {
                    let rel = self.pos - self.origin;
                    (element_bytes - rel % element_bytes) % element_bytes
                } else {
                    0
                };
                bytes + pad <= self.remaining()
            });
        if fits {
            Ok(n as usize)
        } else {
            Err(MessageProblem::CountTooLarge {
                field,
                count: n,
                remaining: self.remaining(),
            })
        }
    }

    /// A count of structures of at least `min_element_bytes` each, all of which must fit in
    /// what is left (no alignment is assumed: a structure aligns its own fields).
    pub(crate) fn count_min(
        &mut self,
        field: &'static str,
        min_element_bytes: usize,
    ) -> Result<usize, MessageProblem> {
        let n = self.u32(field)?;
        let fits = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(min_element_bytes))
            .is_some_and(|bytes| bytes <= self.remaining());
        if fits {
            Ok(n as usize)
        } else {
            Err(MessageProblem::CountTooLarge {
                field,
                count: n,
                remaining: self.remaining(),
            })
        }
    }

    /// A counted sequence of `float32`.
    pub(crate) fn f32_seq(&mut self, field: &'static str) -> Result<Vec<f32>, MessageProblem> {
        let n = self.count(field, 4)?;
        (0..n).map(|_| self.f32(field)).collect()
    }

    /// Skips `n` values of 8 bytes (e.g. a covariance matrix).
    pub(crate) fn skip_f64(&mut self, n: usize, field: &'static str) -> Result<(), MessageProblem> {
        for _ in 0..n {
            self.f64(field)?;
        }
        Ok(())
    }
}

/// Writes one message in a given flavor.
pub(crate) struct Encoder {
    out: Vec<u8>,
    origin: usize,
    flavor: Flavor,
}

impl Encoder {
    pub(crate) fn new(flavor: Flavor) -> Self {
        let out = match flavor {
            Flavor::Ros1 => Vec::new(),
            Flavor::CdrLittle => vec![0, 1, 0, 0],
            Flavor::CdrBig => vec![0, 0, 0, 0],
        };
        let origin = out.len();
        Encoder {
            out,
            origin,
            flavor,
        }
    }

    pub(crate) fn finish(self) -> Vec<u8> {
        self.out
    }

    fn align(&mut self, n: usize) {
        if self.flavor.aligned() {
            while !(self.out.len() - self.origin).is_multiple_of(n) {
                self.out.push(0);
            }
        }
    }

    pub(crate) fn u32(&mut self, v: u32) {
        self.align(4);
        let b = if self.flavor.big() {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        self.out.extend_from_slice(&b);
    }

    pub(crate) fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }

    pub(crate) fn f64(&mut self, v: f64) {
        self.align(8);
        let b = if self.flavor.big() {
            v.to_bits().to_be_bytes()
        } else {
            v.to_bits().to_le_bytes()
        };
        self.out.extend_from_slice(&b);
    }

    /// Writes a string (panics on more than 4 GiB, which no caller writes).
    pub(crate) fn string(&mut self, s: &str) {
        let nul = usize::from(self.flavor.aligned());
        self.u32(u32::try_from(s.len() + nul).unwrap_or(u32::MAX));
        self.out.extend_from_slice(s.as_bytes());
        if nul == 1 {
            self.out.push(0);
        }
    }

    pub(crate) fn f32_seq(&mut self, v: &[f32]) {
        self.u32(u32::try_from(v.len()).unwrap_or(u32::MAX));
        for &x in v {
            self.f32(x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdr_aligns_from_the_byte_after_the_header() {
        let mut e = Encoder::new(Flavor::CdrLittle);
        e.string("ab"); // 4 + 3 bytes, then padding to 8 before a double
        e.f64(1.5);
        let bytes = e.finish();
        assert_eq!(bytes.len(), 4 + 8 + 8);
        let mut d = Decoder::cdr(&bytes).unwrap();
        assert_eq!(d.string("s").unwrap(), "ab");
        assert_eq!(d.f64("x").unwrap(), 1.5);
        d.finish().unwrap();
    }

    #[test]
    fn big_endian_round_trips() {
        let mut e = Encoder::new(Flavor::CdrBig);
        e.f32_seq(&[1.0, -2.5]);
        let bytes = e.finish();
        assert_eq!(&bytes[..4], &[0, 0, 0, 0]);
        assert_eq!(&bytes[4..8], &[0, 0, 0, 2]);
        let mut d = Decoder::cdr(&bytes).unwrap();
        assert_eq!(d.f32_seq("r").unwrap(), vec![1.0, -2.5]);
    }

    #[test]
    fn a_count_beyond_the_message_is_refused_before_allocating() {
        let bytes = [0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff];
        let mut d = Decoder::cdr(&bytes).unwrap();
        assert!(matches!(
            d.f32_seq("ranges"),
            Err(MessageProblem::CountTooLarge {
                count: u32::MAX,
                ..
            })
        ));
    }

    #[test]
    fn an_unknown_encapsulation_is_refused() {
        assert!(matches!(
            Decoder::cdr(&[0, 3, 0, 0]),
            Err(MessageProblem::Encapsulation([0, 3]))
        ));
    }
}
