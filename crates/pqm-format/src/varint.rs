//! LEB128 varints and zigzag signed integers, the integer coding of every
//! `.pqm` stream (spec §1).
//!
//! * unsigned: little-endian base-128, 7 bits per byte, high bit = "more";
//!   at most 10 bytes (a `u64`); a value that does not fit 64 bits is an error;
//! * signed: zigzag first (`0, -1, 1, -2, … → 0, 1, 2, 3, …`), then LEB128.

/// Appends `v` as LEB128.
pub fn put_u(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Zigzag map of a signed value (`0, -1, 1, -2 … → 0, 1, 2, 3 …`).
pub fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// Inverse of [`zigzag`].
pub fn unzigzag(u: u64) -> i64 {
    ((u >> 1) as i64) ^ -((u & 1) as i64)
}

/// Appends `v` zigzag-mapped, as LEB128.
pub fn put_s(out: &mut Vec<u8>, v: i64) {
    put_u(out, zigzag(v));
}

/// A bounds-checked cursor over one stream; errors are plain messages that
/// the caller wraps with the section and record they belong to.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    /// Stream name used in error messages.
    pub name: &'static str,
}

/// The cache of [`Reader::peek_s3_cached`]: three peeked values and the
/// byte position after each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Peek3 {
    /// Values `vals[..n]` are valid (the rest past the end or malformed).
    n: u8,
    vals: [i64; 3],
    ends: [usize; 3],
}

impl<'a> Reader<'a> {
    /// A reader over `buf` named `name`.
    pub fn new(buf: &'a [u8], name: &'static str) -> Self {
        Reader { buf, pos: 0, name }
    }
    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }
    /// The next raw byte, not consumed (`None` at the end).
    #[inline]
    pub fn peek_byte(&self) -> Option<u8> {
        self.buf.get(self.pos).copied()
    }
    /// One raw byte.
    #[inline]
    pub fn byte(&mut self) -> Result<u8, String> {
        let b = *self
            .buf
            .get(self.pos)
            .ok_or_else(|| format!("stream {} ends early", self.name))?;
        self.pos += 1;
        Ok(b)
    }
    /// One unsigned LEB128 value (always inlined: a handful of
    /// instructions per call site on the one- and two-byte paths).
    #[inline(always)]
    pub fn u(&mut self) -> Result<u64, String> {
        // Fast paths: most values in a record fit in one byte, most of the
        // rest (position residuals) in two.
        let pos = self.pos;
        if let Some(&b) = self.buf.get(pos) {
            if b < 0x80 {
                self.pos = pos + 1;
                return Ok(b as u64);
            }
            if let Some(&b1) = self.buf.get(pos + 1) {
                if b1 < 0x80 {
                    self.pos = pos + 2;
                    return Ok((b & 0x7f) as u64 | (b1 as u64) << 7);
                }
            }
        }
        self.u_multi()
    }

    /// [`Reader::u`] for values of three bytes or more (and the errors).
    #[inline(never)]
    fn u_multi(&mut self) -> Result<u64, String> {
        // With 10 bytes left (the longest varint) one fixed-size window is
        // read without a bounds check per byte; nearer the end, the checked
        // loop (same values, same errors).
        if let Some(w) = self.buf.get(self.pos..self.pos + 10) {
            let mut v: u64 = 0;
            for (i, &b) in w.iter().enumerate() {
                let bits = (b & 0x7f) as u64;
                if i == 9 && bits > 1 {
                    return Err(format!("stream {}: varint overflows 64 bits", self.name));
                }
                v |= bits << (7 * i);
                if b & 0x80 == 0 {
                    self.pos += i + 1;
                    return Ok(v);
                }
            }
            return Err(format!("stream {}: varint longer than 10 bytes", self.name));
        }
        let mut v: u64 = 0;
        for i in 0..10 {
            let b = self.byte()?;
            let bits = (b & 0x7f) as u64;
            if i == 9 && bits > 1 {
                return Err(format!("stream {}: varint overflows 64 bits", self.name));
            }
            v |= bits << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(format!("stream {}: varint longer than 10 bytes", self.name))
    }
    /// One unsigned value that must be `<= max` (`what` names it in errors).
    #[inline(always)]
    pub fn u_max(&mut self, max: u64, what: &str) -> Result<u64, String> {
        let v = self.u()?;
        if v > max {
            return Err(too_large(what, v, max));
        }
        Ok(v)
    }
    /// One zigzag-coded signed value.
    #[inline(always)]
    pub fn s(&mut self) -> Result<i64, String> {
        Ok(unzigzag(self.u()?))
    }
    /// The next three zigzag-coded values, without consuming them (`None`
    /// past the end or for a malformed varint): the decoder's look-ahead
    /// for prefetching, never a value it decodes with.
    pub fn peek_s3(&self) -> [Option<i64>; 3] {
        let mut out = [None; 3];
        let mut pos = self.pos;
        for o in out.iter_mut() {
            let Some((v, next)) = self.peek_s_at(pos) else {
                return out;
            };
            *o = Some(v);
            pos = next;
        }
        out
    }

    /// [`Reader::peek_s3`] through `cache`, which holds the last call's
    /// values and where each ended: when this reader has consumed exactly
    /// the first of them since (the decoder's next record read its anchor,
    /// as guessed), the other two are reused and only the third is parsed.
    /// The same values as [`Reader::peek_s3`]; a cache from another reader
    /// (a new chunk) must be reset ([`Peek3::default`]).
    #[inline]
    pub fn peek_s3_cached(&self, cache: &mut Peek3) -> [Option<i64>; 3] {
        let c = cache;
        if c.n > 0 && self.pos == c.ends[0] {
            // Shift by one, in place.
            c.vals = [c.vals[1], c.vals[2], 0];
            c.ends = [c.ends[1], c.ends[2], 0];
            c.n -= 1;
            if c.n == 2 {
                if let Some((v, e)) = self.peek_s_at(c.ends[1]) {
                    (c.vals[2], c.ends[2], c.n) = (v, e, 3);
                }
            }
        } else {
            c.n = 0;
            let mut pos = self.pos;
            while (c.n as usize) < 3 {
                let Some((v, next)) = self.peek_s_at(pos) else {
                    break;
                };
                (c.vals[c.n as usize], c.ends[c.n as usize]) = (v, next);
                c.n += 1;
                pos = next;
            }
        }
        let n = c.n as usize;
        [0, 1, 2].map(|t| (t < n).then_some(c.vals[t]))
    }

    /// The zigzag-coded value at byte `pos` and the position after it,
    /// without consuming it (`None` past the end or malformed).
    #[inline(always)]
    fn peek_s_at(&self, mut pos: usize) -> Option<(i64, usize)> {
        // One- and two-byte values (nearly all anchors' deltas) first.
        let &b = self.buf.get(pos)?;
        if b < 0x80 {
            return Some((unzigzag(b as u64), pos + 1));
        }
        if let Some(&b1) = self.buf.get(pos + 1) {
            if b1 < 0x80 {
                return Some((unzigzag((b & 0x7f) as u64 | (b1 as u64) << 7), pos + 2));
            }
        }
        let mut v: u64 = 0;
        for i in 0..10 {
            let &b = self.buf.get(pos)?;
            pos += 1;
            v |= ((b & 0x7f) as u64).wrapping_shl(7 * i);
            if b & 0x80 == 0 {
                return Some((unzigzag(v), pos));
            }
        }
        None
    }

    /// `n` raw bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.remaining() {
            return Err(format!("stream {} ends early", self.name));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
}

/// The error of [`Reader::u_max`] (cold: only bad input gets here).
#[cold]
#[inline(never)]
fn too_large(what: &str, v: u64, max: u64) -> String {
    format!("{what} = {v} exceeds {max}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn unsigned_and_signed_round_trip(u in any::<u64>(), s in any::<i64>()) {
            let mut out = Vec::new();
            put_u(&mut out, u);
            put_s(&mut out, s);
            let mut r = Reader::new(&out, "t");
            prop_assert_eq!(r.u().unwrap(), u);
            prop_assert_eq!(r.s().unwrap(), s);
            prop_assert_eq!(r.remaining(), 0);
        }
    }

    proptest! {
        /// The windowed fast path (10 bytes left) and the checked loop near
        /// the end of a stream read the same value and the same length, for
        /// any value and any padding after it (0 = the value ends the
        /// stream), and reject the same malformed bytes.
        #[test]
        fn fast_and_checked_paths_agree(u in any::<u64>(), pad in 0usize..12, junk in any::<[u8; 10]>()) {
            let mut out = Vec::new();
            put_u(&mut out, u);
            let len = out.len();
            out.extend(std::iter::repeat_n(0x80u8, pad));
            let mut r = Reader::new(&out, "t");
            prop_assert_eq!(r.u().unwrap(), u);
            prop_assert_eq!(r.remaining(), pad);
            prop_assert_eq!(out.len() - r.remaining(), len);
            // Arbitrary bytes: a varint that ends within the first `k < 10`
            // bytes (the checked loop: fewer than 10 left) reads the same
            // with 10 more bytes after it (the window).
            let k = pad % 10;
            let mut checked = Reader::new(&junk[..k], "t");
            if let Ok(v) = checked.u() {
                let mut padded = junk[..k].to_vec();
                padded.extend([0u8; 10]);
                let mut windowed = Reader::new(&padded, "t");
                prop_assert_eq!(windowed.u().unwrap(), v);
                prop_assert_eq!(windowed.remaining(), 10 + checked.remaining());
            }
        }
    }

    proptest! {
        /// The look-ahead reads what the next three `s()` calls return (as
        /// far as they succeed) and consumes nothing.
        #[test]
        fn peek_sees_the_next_values(
            vals in proptest::collection::vec(any::<i64>(), 0..8),
            cut in 0usize..80,
            skips in proptest::collection::vec(1usize..3, 8),
        ) {
            let mut out = Vec::new();
            for &v in &vals {
                put_s(&mut out, v);
            }
            let out = &out[..cut.min(out.len())];
            let r = Reader::new(out, "t");
            let peeked = r.peek_s3();
            prop_assert_eq!(r.remaining(), out.len());
            // The cached peek, fresh and then after each value read (the
            // cache reused when exactly one value was consumed), equals
            // the plain one.
            let mut cache = Peek3::default();
            let mut r3 = r.clone();
            prop_assert_eq!(r3.peek_s3_cached(&mut cache), peeked);
            'read: for &skip in &skips {
                for _ in 0..skip {
                    if r3.s().is_err() {
                        break 'read;
                    }
                }
                prop_assert_eq!(r3.peek_s3_cached(&mut cache), r3.peek_s3());
            }
            let mut r2 = r.clone();
            for p in peeked {
                match r2.s() {
                    Ok(v) => prop_assert_eq!(p, Some(v)),
                    Err(_) => {
                        prop_assert_eq!(p, None);
                        break;
                    }
                }
            }
        }
    }

    #[test]
    fn overlong_and_truncated_varints_are_errors() {
        assert!(Reader::new(&[0x80; 11], "t").u().is_err());
        assert!(Reader::new(
            &[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02],
            "t"
        )
        .u()
        .is_err());
        assert!(Reader::new(&[0x80], "t").u().is_err());
        assert_eq!(zigzag(-1), 1);
        assert_eq!(zigzag(1), 2);
    }
}
