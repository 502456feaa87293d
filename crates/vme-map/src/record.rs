//! Records of 32-bit words published under a sequence lock (design.md section 4).
//!
//! A [`SeqLock`] slot is a sequence word followed by the record's words. The single writer
//! makes the sequence odd, writes the words, then makes it even again; a reader that sees an
//! odd sequence, or a different sequence before and after reading the words, has raced the
//! writer and retries. After [`SeqLock::RETRIES`] failed attempts the read reports
//! [`Torn`]: readers treat that like missing data and fall back to their safe behaviour.

use crate::bus::GlobalBus;
use core::marker::PhantomData;

/// A value that travels as one big-endian 32-bit word of global RAM.
pub trait Word: Copy {
    /// The word's bits.
    fn to_word(self) -> u32;
    /// The value from the word's bits.
    fn from_word(w: u32) -> Self;
}

impl Word for u32 {
    fn to_word(self) -> u32 {
        self
    }
    fn from_word(w: u32) -> Self {
        w
    }
}

impl Word for i32 {
    fn to_word(self) -> u32 {
        self as u32
    }
    fn from_word(w: u32) -> Self {
        w as i32
    }
}

/// A fixed-size record of 32-bit words.
pub trait Record: Sized {
    /// Number of 32-bit words in the record.
    const WORDS: u32;
    /// Names of the words in order (for the memory-map documentation).
    const FIELDS: &'static [&'static str];
    /// Writes word `i` (0-based) of the record through `put(i, word)`.
    fn encode(&self, put: &mut dyn FnMut(u32, u32));
    /// Builds the record from `get(i)`, which returns word `i`.
    fn decode(get: &mut dyn FnMut(u32) -> u32) -> Self;
}

/// Defines a record struct whose fields are all [`Word`]s, with its [`Record`] impl.
///
/// Field order is the word order in global RAM.
#[macro_export]
macro_rules! record {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$fmeta:meta])* pub $field:ident : $ty:ty ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        // In word order (`repr(C)`), as in global RAM: firmware assembly may address a
        // copy by offset (`sensing::layout`).
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        #[repr(C)]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty ),+
        }

        impl $crate::record::Record for $name {
            const WORDS: u32 = [$(stringify!($field)),+].len() as u32;
            const FIELDS: &'static [&'static str] = &[$(stringify!($field)),+];
            fn encode(&self, put: &mut dyn FnMut(u32, u32)) {
                let mut _i = 0u32;
                $(
                    put(_i, $crate::record::Word::to_word(self.$field));
                    _i += 1;
                )+
            }
            fn decode(get: &mut dyn FnMut(u32) -> u32) -> Self {
                let mut _i = 0u32;
                $(
                    let $field = <$ty as $crate::record::Word>::from_word(get(_i));
                    _i += 1;
                )+
                Self { $($field),+ }
            }
        }

        impl $name {
            /// The record's words in order, as [`$crate::record::SeqLock::publish_raw`]
            /// writes them (no dynamic calls, unlike [`$crate::record::Record::encode`]).
            pub fn to_words(self) -> [u32; <Self as $crate::record::Record>::WORDS as usize] {
                [$($crate::record::Word::to_word(self.$field)),+]
            }

            /// The record from its words, as [`$crate::record::SeqLock::read_raw`] reads
            /// them.
            pub fn from_words(w: &[u32; <Self as $crate::record::Record>::WORDS as usize]) -> Self {
                let mut _i = 0usize;
                $(
                    let $field = <$ty as $crate::record::Word>::from_word(w[_i]);
                    _i += 1;
                )+
                Self { $($field),+ }
            }
        }
    };
}

/// The index among a record's words of the field called `name` (in `fields`, a record's
/// [`Record::FIELDS`]), at compile time; a name that is not there fails the build.
pub const fn word_index(fields: &[&str], name: &str) -> u32 {
    let mut i = 0;
    while i < fields.len() {
        let (a, b) = (fields[i].as_bytes(), name.as_bytes());
        if a.len() == b.len() {
            let mut k = 0;
            while k < a.len() && a[k] == b[k] {
                k += 1;
            }
            if k == a.len() {
                return i as u32;
            }
        }
        i += 1;
    }
    panic!("no such field in the record")
}

/// A read that kept racing the writer: the record is not usable this time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Torn;

/// A record of type `R` published under a sequence lock at a fixed offset.
pub struct SeqLock<R> {
    off: u32,
    _r: PhantomData<R>,
}

impl<R> Clone for SeqLock<R> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<R> Copy for SeqLock<R> {}

impl<R: Record> SeqLock<R> {
    /// How many times a reader retries a torn read before giving up.
    pub const RETRIES: u32 = 4;
    /// Bytes the slot occupies: the sequence word plus the record.
    pub const SIZE: u32 = 4 * (1 + R::WORDS);

    /// The slot at byte offset `off` of global RAM (4-byte aligned).
    pub const fn at(off: u32) -> Self {
        assert!(off.is_multiple_of(4), "seqlock slots are word aligned");
        Self {
            off,
            _r: PhantomData,
        }
    }

    /// Byte offset of the slot (its sequence word).
    pub const fn offset(&self) -> u32 {
        self.off
    }

    /// Offset of the record's word `i` (after the sequence word).
    pub const fn word_offset(&self, i: u32) -> u32 {
        self.off + 4 + 4 * i
    }

    /// The current sequence number (even when no write is in progress).
    pub fn sequence(&self, bus: &mut dyn GlobalBus) -> u32 {
        bus.read_u32(self.off)
    }

    /// Publishes `rec`. Only the record's single writer may call this.
    pub fn publish(&self, bus: &mut dyn GlobalBus, rec: &R) {
        let seq = bus.read_u32(self.off);
        // Odd while writing; a writer that died mid-write leaves it odd, which readers
        // see as a torn record forever. (Without a branch: LLVM's M68k backend put a
        // register copy between the test and its branch here; docs/toolchain.md, class 1.)
        let odd = (seq | 1).wrapping_add((seq & 1) << 1);
        bus.write_u32(self.off, odd);
        let base = self.off + 4;
        rec.encode(&mut |i, w| bus.write_u32(base + 4 * i, w));
        bus.write_u32(self.off, odd.wrapping_add(1));
    }

    /// Publishes words `first..first + N` of the record, leaving the others as they are: for
    /// a writer that changed only part of a large record (the sensing board changes one
    /// beacon of the object table per strobe slot). Readers see the whole record change
    /// atomically as with [`Self::publish`]. Words beyond the record are not written.
    pub fn publish_words<const N: usize>(
        &self,
        bus: &mut dyn GlobalBus,
        first: u32,
        words: &[u32; N],
    ) {
        let seq = bus.read_u32(self.off);
        let odd = (seq | 1).wrapping_add((seq & 1) << 1);
        bus.write_u32(self.off, odd);
        let base = self.off + 4 + 4 * first;
        let mut i = 0;
        while i < N {
            if first + (i as u32) < R::WORDS {
                bus.write_u32(base + 4 * i as u32, words[i]);
            }
            i += 1;
        }
        bus.write_u32(self.off, odd.wrapping_add(1));
    }

    /// Writes only the first half of the record's words and leaves the sequence odd: the
    /// "torn record" fault a writer that stops mid-publish leaves behind. For fault
    /// injection in tests and the simulator.
    pub fn publish_torn(&self, bus: &mut dyn GlobalBus, rec: &R) {
        let seq = bus.read_u32(self.off);
        bus.write_u32(self.off, seq | 1);
        let base = self.off + 4;
        let half = R::WORDS.div_ceil(2);
        rec.encode(&mut |i, w| {
            if i < half {
                bus.write_u32(base + 4 * i, w)
            }
        });
    }

    /// Reads the record, retrying a torn read up to [`Self::RETRIES`] times.
    /// Returns the record and the (even) sequence number it was published under.
    pub fn read(&self, bus: &mut dyn GlobalBus) -> Result<(R, u32), Torn> {
        for _ in 0..Self::RETRIES {
            let s1 = bus.read_u32(self.off);
            let base = self.off + 4;
            let rec = R::decode(&mut |i| bus.read_u32(base + 4 * i));
            let s2 = bus.read_u32(self.off);
            // Whole when the sequence was even and unchanged. One test of one word: a branch
            // on `s1 & 1` drew a register copy between its test and the branch from LLVM's
            // M68k backend (docs/toolchain.md, class 1).
            if (s1 ^ s2) | (s1 & 1) == 0 {
                return Ok((rec, s1));
            }
        }
        Err(Torn)
    }

    /// Reads the record's `N` (= `R::WORDS`) words into `out` under the lock, as
    /// [`Self::read`] does, without decoding: generic over the bus, so on the 68020 the
    /// words come in one copy loop ([`GlobalBus::read_words`]) instead of two dynamic calls
    /// each (the reflex reads the 33-word object table every pass). Returns the sequence
    /// number.
    #[inline(never)]
    pub fn read_raw<G: GlobalBus + ?Sized, const N: usize>(
        &self,
        bus: &mut G,
        out: &mut [u32; N],
    ) -> Result<u32, Torn> {
        debug_assert_eq!(N as u32, R::WORDS);
        let base = self.off + 4;
        let mut tries = 0;
        while tries < Self::RETRIES {
            let s1 = bus.read_u32(self.off);
            bus.read_words(base, out);
            let s2 = bus.read_u32(self.off);
            // Whole when the sequence was even and did not change: one test on a mask.
            if ((s1 ^ s2) | (s1 & 1)) == 0 {
                return Ok(s1);
            }
            tries += 1;
        }
        Err(Torn)
    }

    /// Publishes the record from its `N` (= `R::WORDS`) words, as [`Self::publish`] does,
    /// generic over the bus (see [`Self::read_raw`]).
    #[inline(never)]
    pub fn publish_raw<G: GlobalBus + ?Sized, const N: usize>(
        &self,
        bus: &mut G,
        words: &[u32; N],
    ) {
        debug_assert_eq!(N as u32, R::WORDS);
        let seq = bus.read_u32(self.off);
        // (seq | 1) + 2 when seq is odd (a writer died mid-write), + 0 when even.
        let odd = (seq | 1).wrapping_add((seq & 1) << 1);
        bus.write_u32(self.off, odd);
        // The words in one call (on the 68020 one copy loop: a write call a word cost the
        // reflex ~630 cycles a pass for its two records).
        bus.write_words(self.off + 4, words);
        bus.write_u32(self.off, odd.wrapping_add(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::ArrayBus;

    #[test]
    fn raw_reads_and_writes_match_the_decoded_ones() {
        let mut mem = [0u8; 256];
        let mut bus = ArrayBus::new(&mut mem);
        let lock: SeqLock<Pair> = SeqLock::at(16);
        lock.publish_raw(&mut bus, &[7, (-3i32) as u32, 9]);
        let (p, seq) = lock.read(&mut bus).unwrap();
        assert_eq!(p, Pair { a: 7, b: -3, c: 9 });
        assert_eq!(seq, 2);
        lock.publish(&mut bus, &Pair { a: 1, b: 2, c: 3 });
        let mut w = [0u32; 3];
        assert_eq!(lock.read_raw(&mut bus, &mut w), Ok(4));
        assert_eq!(w, [1, 2, 3]);
        lock.publish_torn(&mut bus, &Pair { a: 5, b: 6, c: 7 });
        assert_eq!(lock.read_raw(&mut bus, &mut w), Err(Torn));
        // A writer that died mid-write: the next publication starts from an odd sequence.
        lock.publish_raw(&mut bus, &[8, 8, 8]);
        assert_eq!(
            lock.read(&mut bus).map(|r| r.0),
            Ok(Pair { a: 8, b: 8, c: 8 })
        );
    }

    crate::record! {
        /// Test record.
        pub struct Pair {
            /// a
            pub a: u32,
            /// b
            pub b: i32,
            /// c
            pub c: u32,
        }
    }

    #[test]
    fn publishing_some_words_changes_only_those_and_the_sequence() {
        let mut mem = [0u8; 64];
        let mut bus = ArrayBus::new(&mut mem);
        let slot = SeqLock::<Pair>::at(8);
        slot.publish(&mut bus, &Pair { a: 1, b: -2, c: 3 });
        let s0 = slot.sequence(&mut bus);
        slot.publish_words(&mut bus, 1, &[20, 30]);
        let (p, s1) = slot.read(&mut bus).unwrap();
        assert_eq!(p, Pair { a: 1, b: 20, c: 30 });
        assert_eq!(s1, s0 + 2);
        // Words past the record are dropped, not written over the next slot.
        slot.publish_words(&mut bus, 2, &[7, 99]);
        assert_eq!(slot.read(&mut bus).unwrap().0.c, 7);
        assert_eq!(bus.read_u32(8 + 4 * 4), 0);
    }

    /// The words `to_words` gives are `encode`'s, and `from_words` inverts both; the word
    /// index of a field is its place in the record.
    #[test]
    fn words_match_the_encoding_and_round_trip() {
        let p = Pair {
            a: 7,
            b: -9,
            c: 0x8000_0001,
        };
        let mut enc = [0u32; 3];
        p.encode(&mut |i, w| enc[i as usize] = w);
        assert_eq!(p.to_words(), enc);
        assert_eq!(Pair::from_words(&enc), p);
        assert_eq!(word_index(Pair::FIELDS, "c"), 2);
        assert_eq!(word_index(Pair::FIELDS, "a"), 0);
    }

    #[test]
    fn publish_then_read_round_trips() {
        let mut mem = [0u8; 64];
        let mut bus = ArrayBus::new(&mut mem);
        let slot = SeqLock::<Pair>::at(8);
        let p = Pair {
            a: 1,
            b: -2,
            c: 0xdead_beef,
        };
        slot.publish(&mut bus, &p);
        let (q, seq) = slot.read(&mut bus).unwrap();
        assert_eq!(p, q);
        assert_eq!(seq, 2);
        slot.publish(&mut bus, &p);
        assert_eq!(slot.sequence(&mut bus), 4);
        assert_eq!(SeqLock::<Pair>::SIZE, 16);
    }

    #[test]
    fn torn_record_is_detected_not_returned() {
        let mut mem = [0u8; 64];
        let mut bus = ArrayBus::new(&mut mem);
        let slot = SeqLock::<Pair>::at(0);
        slot.publish(&mut bus, &Pair { a: 1, b: 1, c: 1 });
        slot.publish_torn(&mut bus, &Pair { a: 9, b: 9, c: 9 });
        assert_eq!(slot.read(&mut bus), Err(Torn));
        // The writer recovers: the next complete publish is readable again.
        slot.publish(&mut bus, &Pair { a: 7, b: 7, c: 7 });
        assert_eq!(slot.read(&mut bus).unwrap().0, Pair { a: 7, b: 7, c: 7 });
    }

    /// A bus on which the writer strikes between the reader's accesses: a model of the
    /// asynchronous boards of the VME system.
    struct RacingBus<'a> {
        inner: ArrayBus<'a>,
        reads: u32,
        strike_at: u32,
    }
    impl GlobalBus for RacingBus<'_> {
        fn read_u32(&mut self, off: u32) -> u32 {
            self.reads += 1;
            if self.reads == self.strike_at {
                // The writer changes word 1 and bumps the sequence by 2.
                let s = self.inner.read_u32(0);
                self.inner.write_u32(4, 1000);
                self.inner.write_u32(0, s + 2);
            }
            self.inner.read_u32(off)
        }
        fn write_u32(&mut self, off: u32, val: u32) {
            self.inner.write_u32(off, val)
        }
        fn read_u8(&mut self, off: u32) -> u8 {
            self.inner.read_u8(off)
        }
        fn write_u8(&mut self, off: u32, val: u8) {
            self.inner.write_u8(off, val)
        }
        fn cas_u32(&mut self, off: u32, c: u32, n: u32) -> u32 {
            self.inner.cas_u32(off, c, n)
        }
    }

    #[test]
    fn a_write_during_the_read_forces_a_retry() {
        // Reads of one attempt: 1 = first sequence, 2..=4 = words, 5 = second sequence.
        for strike in 1..=5u32 {
            let mut mem = [0u8; 64];
            let mut racing = RacingBus {
                inner: ArrayBus::new(&mut mem),
                reads: 0,
                strike_at: 0,
            };
            let slot = SeqLock::<Pair>::at(0);
            slot.publish(&mut racing, &Pair { a: 5, b: 5, c: 5 });
            racing.reads = 0;
            racing.strike_at = strike;
            let (rec, seq) = slot.read(&mut racing).unwrap();
            // Whatever the interleaving, the reader returns the new record whole.
            assert_eq!(
                rec,
                Pair {
                    a: 1000,
                    b: 5,
                    c: 5
                },
                "strike at read {strike}"
            );
            assert_eq!(seq, 4);
            let retried = racing.reads > 5;
            assert_eq!(
                retried,
                strike > 1,
                "strike at read {strike}: retried={retried}"
            );
        }
    }
}
