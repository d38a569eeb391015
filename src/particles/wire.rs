//! The wire format of particle records: little-endian 8-byte words, with small integer fields
//! (kind, body, material) packed into shared words in table order.
//!
//! A [`Sink`] receives a record field by field; [`Words`] appends the bytes to a message and
//! [`Count`] only counts the words, so the size of a record is derived from the same code that
//! writes it. [`Reader`] reads in the same order. Packing rule (writer and reader alike): a
//! small field goes into the current packed word if it fits in the bits left, else a new word
//! starts; a whole-word field closes the packed word.

use crate::error::{Error, Result};

/// Receives the fields of one record in table order.
pub trait Sink {
    /// A small unsigned field of `bits` bits (≤ 64), packed with its neighbours.
    fn bits(&mut self, value: u64, bits: u32);
    /// A whole 8-byte word.
    fn word(&mut self, value: u64);
    /// Close the record (flushes a partly filled packed word).
    fn end(&mut self);
}

/// Bit packing state shared by the sinks.
#[derive(Debug, Default, Clone, Copy)]
struct Packing {
    acc: u64,
    used: u32,
    open: bool,
}

impl Packing {
    /// Add `value` of `bits` bits; returns a full word to emit first, if any.
    #[inline]
    fn push(&mut self, value: u64, bits: u32) -> Option<u64> {
        let mut out = None;
        if self.open && self.used + bits > 64 {
            out = Some(self.acc);
            self.open = false;
        }
        if !self.open {
            self.acc = 0;
            self.used = 0;
            self.open = true;
        }
        self.acc |= value << self.used;
        self.used += bits;
        out
    }

    /// Close the packed word; returns it if one was open.
    #[inline]
    fn close(&mut self) -> Option<u64> {
        let out = self.open.then_some(self.acc);
        self.open = false;
        out
    }
}

/// A sink that appends the record's words to a byte buffer.
pub struct Words<'a> {
    buf: &'a mut Vec<u8>,
    pack: Packing,
}

impl<'a> Words<'a> {
    /// Append to `buf`.
    pub fn new(buf: &'a mut Vec<u8>) -> Self {
        Words {
            buf,
            pack: Packing::default(),
        }
    }
}

impl Sink for Words<'_> {
    #[inline]
    fn bits(&mut self, value: u64, bits: u32) {
        if let Some(w) = self.pack.push(value, bits) {
            self.buf.extend_from_slice(&w.to_le_bytes());
        }
    }
    #[inline]
    fn word(&mut self, value: u64) {
        self.end();
        self.buf.extend_from_slice(&value.to_le_bytes());
    }
    #[inline]
    fn end(&mut self) {
        if let Some(w) = self.pack.close() {
            self.buf.extend_from_slice(&w.to_le_bytes());
        }
    }
}

/// A sink that only counts words.
#[derive(Default)]
pub struct Count {
    /// Words so far.
    pub words: usize,
    pack: Packing,
}

impl Sink for Count {
    fn bits(&mut self, value: u64, bits: u32) {
        if self.pack.push(value, bits).is_some() {
            self.words += 1;
        }
    }
    fn word(&mut self, _value: u64) {
        self.end();
        self.words += 1;
    }
    fn end(&mut self) {
        if self.pack.close().is_some() {
            self.words += 1;
        }
    }
}

/// Reads the words of records in the order a [`Sink`] wrote them.
pub struct Reader<'a> {
    b: &'a [u8],
    at: usize,
    cur: u64,
    used: u32,
    open: bool,
}

impl<'a> Reader<'a> {
    /// Read from the start of `b`.
    pub fn new(b: &'a [u8]) -> Self {
        Reader {
            b,
            at: 0,
            cur: 0,
            used: 0,
            open: false,
        }
    }

    fn next(&mut self) -> Result<u64> {
        let bytes = self
            .b
            .get(self.at..self.at + 8)
            .ok_or_else(|| Error::run("particle record: message ends inside a record"))?;
        self.at += 8;
        Ok(u64::from_le_bytes(bytes.try_into().expect("8 bytes")))
    }

    /// A whole word.
    #[inline]
    pub fn word(&mut self) -> Result<u64> {
        self.open = false;
        self.next()
    }

    /// A small field of `bits` bits.
    #[inline]
    pub fn bits(&mut self, bits: u32) -> Result<u64> {
        if !self.open || self.used + bits > 64 {
            self.cur = self.next()?;
            self.used = 0;
            self.open = true;
        }
        let mask = if bits == 64 { u64::MAX } else { (1u64 << bits) - 1 };
        let v = (self.cur >> self.used) & mask;
        self.used += bits;
        Ok(v)
    }

    /// End of one record: the next small field starts a new word.
    #[inline]
    pub fn end(&mut self) {
        self.open = false;
    }

    /// True once every byte has been read.
    pub fn done(&self) -> bool {
        self.at == self.b.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_fields_share_words_and_read_back() {
        let mut buf = Vec::new();
        let mut w = Words::new(&mut buf);
        w.word(7);
        w.bits(2, 8);
        w.bits(0xffff, 16);
        w.bits(3, 16);
        w.word(f64::to_bits(1.5));
        w.bits(1, 40);
        w.bits(1, 40); // does not fit: a new word
        w.end();
        let mut c = Count::default();
        c.word(0);
        c.bits(0, 8);
        c.bits(0, 16);
        c.bits(0, 16);
        c.word(0);
        c.bits(0, 40);
        c.bits(0, 40);
        c.end();
        assert_eq!(buf.len(), 8 * 5);
        assert_eq!(c.words, 5);
        let mut r = Reader::new(&buf);
        assert_eq!(r.word().unwrap(), 7);
        assert_eq!(r.bits(8).unwrap(), 2);
        assert_eq!(r.bits(16).unwrap(), 0xffff);
        assert_eq!(r.bits(16).unwrap(), 3);
        assert_eq!(f64::from_bits(r.word().unwrap()), 1.5);
        assert_eq!(r.bits(40).unwrap(), 1);
        assert_eq!(r.bits(40).unwrap(), 1);
        r.end();
        assert!(r.done());
        assert!(r.word().is_err());
    }
}
