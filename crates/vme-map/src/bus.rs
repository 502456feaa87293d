//! Access to global RAM: the [`GlobalBus`] trait and its implementations.
//!
//! Boards never hold Rust references into global RAM; they read and write aligned words at
//! offsets through this trait, so the same board code runs on the 68020 (volatile MMIO),
//! in unit tests ([`ArrayBus`]) and in the simulator's native mode.

/// Word and byte access to global RAM at byte offsets from [`crate::GLOBAL_RAM_BASE`].
///
/// Words are big-endian and 32-bit accesses must be 4-byte aligned; implementations may
/// panic on a misaligned offset (it is a programming error, never a data error).
pub trait GlobalBus {
    /// Reads the aligned 32-bit word at `off`.
    fn read_u32(&mut self, off: u32) -> u32;
    /// Writes the aligned 32-bit word at `off`.
    fn write_u32(&mut self, off: u32, val: u32);
    /// Reads the byte at `off`.
    fn read_u8(&mut self, off: u32) -> u8;
    /// Writes the byte at `off`.
    fn write_u8(&mut self, off: u32, val: u8);
    /// Atomically replaces the word at `off` with `new` if it equals `current` (the 68020's
    /// `CAS.L`, an indivisible read-modify-write cycle on the VME bus). Returns the value
    /// found, so the swap happened exactly when the result equals `current`.
    fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32;
    /// Raises the word at `off` by one, atomically against every other writer (a `CAS.L`
    /// loop: a plain read and write could lose another board's raise). Generation counters
    /// (`layout::CSPACE_GENS`).
    fn raise_u32(&mut self, off: u32) {
        let mut v = self.read_u32(off);
        loop {
            let found = self.cas_u32(off, v, v.wrapping_add(1));
            if found == v {
                return;
            }
            v = found;
        }
    }
    /// Raises the word at `first`, then the word at `then`, each as [`GlobalBus::raise_u32`]:
    /// a column's generation and the map's epoch (`layout::raise_column_gen`), in one call
    /// of the runtime's assembly on the 68020.
    fn raise_u32_then(&mut self, first: u32, then: u32) {
        self.raise_u32(first);
        self.raise_u32(then);
    }
    /// The bitwise or of `n` aligned words from `off`, `stride` bytes apart: a row or a
    /// column of the C-space map tested for obstacles in one call (the reflex's inner loop;
    /// on the 68020 a two-instruction loop in the runtime's assembly).
    fn or_words(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        let mut acc = 0;
        let mut a = off;
        let mut i = 0;
        while i < n {
            acc |= self.read_u32(a);
            a += stride;
            i += 1;
        }
        acc
    }
    /// How many rows of a rectangle, from its first, have every word zero: row `k` is the
    /// `n0` aligned words from `off0 + k * stride` and the `n1` from `off1 + k * stride`,
    /// and no row past the first with a nonzero word is read (`rows` when none has one).
    /// The reflex's window test of a rectangle of C-space pixels in one call (on the 68020
    /// `OR.L (An)+` loops in the runtime's assembly).
    fn free_rows(&mut self, off0: u32, n0: u32, off1: u32, n1: u32, rows: u32, stride: u32) -> u32 {
        let mut k = 0;
        while k < rows {
            let d = k * stride;
            if self.or_words(off0 + d, n0, 4) | self.or_words(off1 + d, n1, 4) != 0 {
                return k;
            }
            k += 1;
        }
        rows
    }
    /// A column of the C-space map as up to five runs: `pieces` holds five (rows, mask)
    /// pairs taken in order down the column whose pixel in map row 0 is at `col_off`, from
    /// map row `row` (0..128), wrapping from the last row to the first. The first `skip`
    /// pixels are passed over; each other gets `mask` added (`down`: subtracted) while that
    /// is a plain word add ([`crate::layout::counter_fast`]), stopping before the first that
    /// needs the byte-by-byte update, which is left as it was. Returns that pixel's
    /// index from the column's first (skip included), or the column's pixel count: a whole
    /// column of an image in one call (on the 68020 the runtime's assembly).
    fn count_column(
        &mut self,
        col_off: u32,
        row: u32,
        pieces: &[u32; 10],
        skip: u32,
        down: bool,
    ) -> u32 {
        // Piece by piece through [`GlobalBus::count_run`], from the first pixel past `skip`.
        let mut k = 0;
        let mut p = 0;
        while p < 5 {
            let (n, mask) = (pieces[2 * p], pieces[2 * p + 1]);
            let from = skip.saturating_sub(k).min(n);
            let done = self.count_run(col_off, row.wrapping_add(k + from), n - from, mask, down);
            if done < n - from {
                return k + from + done;
            }
            k += n;
            p += 1;
        }
        k
    }
    /// One run of a C-space map column: from map row `row` (taken mod 128) of the column
    /// whose pixel in map row 0 is at `col_off`, wrapping from the last row to the first,
    /// each of `rows` pixels gets `mask` added (`down`: subtracted) while that is a plain
    /// word add ([`crate::layout::counter_fast`]), stopping before the first that needs the
    /// byte-by-byte update, which is left as it was. Returns how many were updated (`rows`
    /// when all): a run of a moved image's differences in one call (on the 68020 the
    /// runtime's assembly).
    fn count_run(&mut self, col_off: u32, row: u32, rows: u32, mask: u32, down: bool) -> u32 {
        use crate::layout::{counter_fast, counter_plain, CSPACE_COUNTERS, CSPACE_SIDE};
        let mut k = 0;
        while k < rows {
            let r = row.wrapping_add(k) % CSPACE_SIDE;
            let off = col_off + r * CSPACE_SIDE * CSPACE_COUNTERS;
            let w = self.read_u32(off);
            if !counter_fast(w, mask, down) {
                return k;
            }
            self.write_u32(off, counter_plain(w, mask, down));
            k += 1;
        }
        rows
    }
    /// Reads `out.len()` consecutive aligned words from `off` into `out`, in order: a
    /// record's words under its sequence lock in one call (on the 68020 a `MOVE.L (A0)+,
    /// (A1)+` loop in the runtime's assembly).
    fn read_words(&mut self, off: u32, out: &mut [u32]) {
        let mut a = off;
        for w in out.iter_mut() {
            *w = self.read_u32(a);
            a += 4;
        }
    }
    /// Writes `words` to consecutive aligned words from `off`, in order: a record's words
    /// under its sequence lock in one call (on the 68020 the same copy loop as
    /// [`GlobalBus::read_words`], the other way).
    fn write_words(&mut self, off: u32, words: &[u32]) {
        let mut a = off;
        for &w in words {
            self.write_u32(a, w);
            a += 4;
        }
    }
    /// How many of the `n` aligned words from `off`, `stride` bytes apart, are zero before
    /// the first that is not (`n` when none is): the free rows of a C-space map column from
    /// a row (on the 68020 a `TST.L` loop in the runtime's assembly).
    fn zero_run(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        let mut k = 0;
        while k < n && self.read_u32(off + k * stride) == 0 {
            k += 1;
        }
        k
    }
    /// Bit `k` set when the `k`-th of the 32 consecutive aligned words from `off` is
    /// nonzero: 32 pixels of a C-space map row as one word of the planner's bitmap (on the
    /// 68020 an unrolled `NEG.L` / `ADDX.L` run in the runtime's assembly).
    fn nonzero_bits(&mut self, off: u32) -> u32 {
        self.nonzero_bits_strided(off, 32, 4)
    }
    /// Bit `k` set when the `k`-th of the `n` aligned words `stride` bytes apart from `off`
    /// is nonzero (`n` <= 32): a run of a C-space map column as a word of bits (on the
    /// 68020 a `NEG.L` / `ADDX.L` loop in the runtime's assembly).
    fn nonzero_bits_strided(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        let mut bits = 0;
        let mut k = 0;
        while k < n {
            let w = self.read_u32(off + k * stride);
            bits |= ((w | w.wrapping_neg()) >> 31) << k;
            k += 1;
        }
        bits
    }
    /// The address of the aligned word at `off` where global RAM is memory-mapped (the
    /// 68020's VME window), for assembly routines that walk a table in place (the sensing
    /// board's calibration lookup); `None` on buses that are not (the host's models), whose
    /// users take the word-by-word path instead.
    fn word_ptr(&mut self, off: u32) -> Option<*const u32> {
        let _ = off;
        None
    }
}

/// A borrowed bus is a bus: lets code generic over a sized `G: GlobalBus` (inlined accesses
/// on the 68020) also run on a `&mut dyn GlobalBus` (the simulator's native mode).
impl<T: GlobalBus + ?Sized> GlobalBus for &mut T {
    fn read_u32(&mut self, off: u32) -> u32 {
        (**self).read_u32(off)
    }
    fn write_u32(&mut self, off: u32, val: u32) {
        (**self).write_u32(off, val)
    }
    fn read_u8(&mut self, off: u32) -> u8 {
        (**self).read_u8(off)
    }
    fn write_u8(&mut self, off: u32, val: u8) {
        (**self).write_u8(off, val)
    }
    fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32 {
        (**self).cas_u32(off, current, new)
    }
    fn raise_u32(&mut self, off: u32) {
        (**self).raise_u32(off)
    }
    fn raise_u32_then(&mut self, first: u32, then: u32) {
        (**self).raise_u32_then(first, then)
    }
    fn or_words(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        (**self).or_words(off, n, stride)
    }
    fn nonzero_bits(&mut self, off: u32) -> u32 {
        (**self).nonzero_bits(off)
    }
    fn nonzero_bits_strided(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        (**self).nonzero_bits_strided(off, n, stride)
    }
    fn zero_run(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        (**self).zero_run(off, n, stride)
    }
    fn free_rows(&mut self, off0: u32, n0: u32, off1: u32, n1: u32, rows: u32, stride: u32) -> u32 {
        (**self).free_rows(off0, n0, off1, n1, rows, stride)
    }
    fn count_run(&mut self, col_off: u32, row: u32, rows: u32, mask: u32, down: bool) -> u32 {
        (**self).count_run(col_off, row, rows, mask, down)
    }
    fn read_words(&mut self, off: u32, out: &mut [u32]) {
        (**self).read_words(off, out)
    }
    fn write_words(&mut self, off: u32, words: &[u32]) {
        (**self).write_words(off, words)
    }
    fn count_column(
        &mut self,
        col_off: u32,
        row: u32,
        pieces: &[u32; 10],
        skip: u32,
        down: bool,
    ) -> u32 {
        (**self).count_column(col_off, row, pieces, skip, down)
    }
}

/// Global RAM backed by a byte slice, for unit tests and the host simulator.
///
/// The slice may be shorter than 8 MiB; accesses beyond it panic.
pub struct ArrayBus<'a> {
    mem: &'a mut [u8],
}

impl<'a> ArrayBus<'a> {
    /// Wraps `mem` as global RAM starting at offset 0.
    pub fn new(mem: &'a mut [u8]) -> Self {
        Self { mem }
    }
}

impl GlobalBus for ArrayBus<'_> {
    fn read_u32(&mut self, off: u32) -> u32 {
        debug_assert!(
            off.is_multiple_of(4),
            "misaligned global RAM read at {off:#x}"
        );
        let o = off as usize;
        u32::from_be_bytes([
            self.mem[o],
            self.mem[o + 1],
            self.mem[o + 2],
            self.mem[o + 3],
        ])
    }
    fn write_u32(&mut self, off: u32, val: u32) {
        debug_assert!(
            off.is_multiple_of(4),
            "misaligned global RAM write at {off:#x}"
        );
        let o = off as usize;
        self.mem[o..o + 4].copy_from_slice(&val.to_be_bytes());
    }
    fn or_words(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        // One bounds-checked slice per word instead of a call per byte (the native
        // simulation's reflex tests thousands of pixels a millisecond).
        let (o, st) = (off as usize, stride as usize);
        let mut acc = 0u32;
        for k in 0..n as usize {
            let w = &self.mem[o + k * st..o + k * st + 4];
            acc |= u32::from_be_bytes([w[0], w[1], w[2], w[3]]);
        }
        acc
    }
    fn nonzero_bits_strided(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        let (o, st) = (off as usize, stride as usize);
        let mut bits = 0u32;
        for k in 0..n as usize {
            bits |= ((self.mem[o + k * st..o + k * st + 4] != [0, 0, 0, 0]) as u32) << k;
        }
        bits
    }
    fn read_u8(&mut self, off: u32) -> u8 {
        self.mem[off as usize]
    }
    fn write_u8(&mut self, off: u32, val: u8) {
        self.mem[off as usize] = val;
    }
    fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32 {
        let found = self.read_u32(off);
        if found == current {
            self.write_u32(off, new);
        }
        found
    }
}

/// Global RAM through the board's VME window: volatile accesses at
/// [`crate::GLOBAL_RAM_BASE`]` + off`. Only meaningful on the 68020 boards.
#[cfg(target_arch = "m68k")]
pub struct MmioGlobal(());

#[cfg(target_arch = "m68k")]
impl MmioGlobal {
    /// Creates the accessor.
    ///
    /// # Safety
    /// The caller must run on a board whose bus maps global RAM at [`crate::GLOBAL_RAM_BASE`].
    pub const unsafe fn new() -> Self {
        Self(())
    }
    #[inline(always)]
    fn ptr<T>(off: u32) -> *mut T {
        (crate::GLOBAL_RAM_BASE + off) as *mut T
    }
}

#[cfg(target_arch = "m68k")]
impl GlobalBus for MmioGlobal {
    #[inline(always)]
    fn read_u32(&mut self, off: u32) -> u32 {
        // SAFETY: `new`'s contract: the window is mapped; offsets come from `layout`.
        unsafe { core::ptr::read_volatile(Self::ptr::<u32>(off)) }
    }
    #[inline(always)]
    fn write_u32(&mut self, off: u32, val: u32) {
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile(Self::ptr::<u32>(off), val) }
    }
    #[inline(always)]
    fn read_u8(&mut self, off: u32) -> u8 {
        // SAFETY: as above.
        unsafe { core::ptr::read_volatile(Self::ptr::<u8>(off)) }
    }
    #[inline(always)]
    fn write_u8(&mut self, off: u32, val: u8) {
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile(Self::ptr::<u8>(off), val) }
    }
    #[inline(always)]
    fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32 {
        extern "C" {
            // `CAS.L` in the runtime's assembly (crates/rt/asm/rt.S), linked into every image.
            fn __vme_cas32(addr: *mut u32, current: u32, new: u32) -> u32;
        }
        // SAFETY: an aligned, mapped global RAM word; CAS.L touches only that word.
        unsafe { __vme_cas32(Self::ptr::<u32>(off), current, new) }
    }
    #[inline(always)]
    fn zero_run(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        extern "C" {
            // A `TST.L` / `ADDA.L` loop in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_zero_run(addr: *const u32, n: u32, stride: u32) -> u32;
        }
        // SAFETY: `n` aligned, mapped global RAM words `stride` bytes apart, only read.
        unsafe { __vme_zero_run(Self::ptr::<u32>(off), n, stride) }
    }
    #[inline(always)]
    fn raise_u32(&mut self, off: u32) {
        extern "C" {
            // A `CAS.L` loop in the runtime's assembly (crates/rt/asm/rt.S): the compiled
            // loop branched on the flags of a register copy (docs/toolchain.md, class 1).
            fn __vme_raise32(addr: *mut u32);
        }
        // SAFETY: an aligned, mapped global RAM word; the loop touches only that word.
        unsafe { __vme_raise32(Self::ptr::<u32>(off)) }
    }
    #[inline(always)]
    fn raise_u32_then(&mut self, first: u32, then: u32) {
        extern "C" {
            // Two `CAS.L` loops in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_raise32_then(first: *mut u32, then: *mut u32);
        }
        // SAFETY: aligned, mapped global RAM words; the loops touch only those words.
        unsafe { __vme_raise32_then(Self::ptr::<u32>(first), Self::ptr::<u32>(then)) }
    }
    #[inline(always)]
    fn or_words(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        extern "C" {
            // `OR.L (An)+` / `ADDA` loops in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_or_words(addr: *const u32, n: u32, stride: u32) -> u32;
        }
        // SAFETY: `n` aligned words of mapped global RAM, only read.
        unsafe { __vme_or_words(Self::ptr::<u32>(off), n, stride) }
    }
    #[inline(always)]
    fn free_rows(&mut self, off0: u32, n0: u32, off1: u32, n1: u32, rows: u32, stride: u32) -> u32 {
        extern "C" {
            // `OR.L (An)+` loops over each row's two runs in the runtime's assembly
            // (crates/rt/asm/rt.S).
            fn __vme_free_rows(
                r0: *const u32,
                n0: u32,
                r1: *const u32,
                n1: u32,
                rows: u32,
                stride: u32,
            ) -> u32;
        }
        // SAFETY: `rows` rows of `n0` and `n1` aligned words of mapped global RAM from
        // `off0` and `off1` (offsets from `layout`), only read.
        unsafe {
            __vme_free_rows(
                Self::ptr::<u32>(off0),
                n0,
                Self::ptr::<u32>(off1),
                n1,
                rows,
                stride,
            )
        }
    }
    fn nonzero_bits(&mut self, off: u32) -> u32 {
        extern "C" {
            // An unrolled `NEG.L` / `ADDX.L` run in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_nonzero_bits(addr: *const u32) -> u32;
        }
        // SAFETY: 32 aligned words of mapped global RAM, only read.
        unsafe { __vme_nonzero_bits(Self::ptr::<u32>(off)) }
    }
    #[inline(always)]
    fn nonzero_bits_strided(&mut self, off: u32, n: u32, stride: u32) -> u32 {
        extern "C" {
            // A `NEG.L` / `ADDX.L` loop in the runtime's assembly (crates/rt/asm/rt.S), from
            // the last word down.
            fn __vme_nonzero_bits_strided(last: *const u32, n: u32, stride: u32) -> u32;
        }
        if n == 0 {
            return 0;
        }
        // SAFETY: `n` aligned words of mapped global RAM `stride` bytes apart from `off`,
        // only read.
        unsafe { __vme_nonzero_bits_strided(Self::ptr::<u32>(off + (n - 1) * stride), n, stride) }
    }
    #[inline(always)]
    fn count_run(&mut self, col_off: u32, row: u32, rows: u32, mask: u32, down: bool) -> u32 {
        extern "C" {
            // An `ADD.L` / `SUB.L` loop in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_count_run(col: *mut u32, row: u32, rows: u32, mask: u32, down: u32) -> u32;
        }
        // SAFETY: the column's 128 aligned words of mapped global RAM from `col_off` (from
        // `layout`), read and written back by this board alone (its work-list claim).
        unsafe { __vme_count_run(Self::ptr::<u32>(col_off), row, rows, mask, down as u32) }
    }
    #[inline(always)]
    fn count_column(
        &mut self,
        col_off: u32,
        row: u32,
        pieces: &[u32; 10],
        skip: u32,
        down: bool,
    ) -> u32 {
        extern "C" {
            // Runs of `ADD.L` / `SUB.L` loops in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_count_column(
                col: *mut u32,
                row: u32,
                pieces: *const u32,
                skip: u32,
                down: u32,
            ) -> u32;
        }
        // SAFETY: the column's 128 aligned words of mapped global RAM from `col_off` (from
        // `layout`), read and written back by this board alone (its work-list claim);
        // `pieces` is read only.
        unsafe {
            __vme_count_column(
                Self::ptr::<u32>(col_off),
                row,
                pieces.as_ptr(),
                skip,
                down as u32,
            )
        }
    }
    #[inline(always)]
    fn read_words(&mut self, off: u32, out: &mut [u32]) {
        extern "C" {
            // A `MOVE.L (A0)+, (A1)+` loop in the runtime's assembly (crates/rt/asm/rt.S).
            fn __vme_read_words(src: *const u32, dst: *mut u32, n: u32);
        }
        // SAFETY: `out.len()` aligned words of mapped global RAM from `off` (offsets come
        // from `layout`), copied into `out`, which the routine writes only within.
        unsafe { __vme_read_words(Self::ptr::<u32>(off), out.as_mut_ptr(), out.len() as u32) }
    }
    fn write_words(&mut self, off: u32, words: &[u32]) {
        extern "C" {
            // The same `MOVE.L (A0)+, (A1)+` loop, local RAM to global.
            fn __vme_read_words(src: *const u32, dst: *mut u32, n: u32);
        }
        // SAFETY: `words.len()` aligned words of mapped global RAM from `off` (offsets come
        // from `layout`), written from `words` only within them.
        unsafe { __vme_read_words(words.as_ptr(), Self::ptr::<u32>(off), words.len() as u32) }
    }
    #[inline(always)]
    fn word_ptr(&mut self, off: u32) -> Option<*const u32> {
        Some(Self::ptr::<u32>(off))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bus with only the required methods: the trait's own `or_words`.
    struct Plain<'a>(ArrayBus<'a>);
    impl GlobalBus for Plain<'_> {
        fn read_u32(&mut self, off: u32) -> u32 {
            self.0.read_u32(off)
        }
        fn write_u32(&mut self, off: u32, val: u32) {
            self.0.write_u32(off, val)
        }
        fn read_u8(&mut self, off: u32) -> u8 {
            self.0.read_u8(off)
        }
        fn write_u8(&mut self, off: u32, val: u8) {
            self.0.write_u8(off, val)
        }
        fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32 {
            self.0.cas_u32(off, current, new)
        }
    }

    #[test]
    fn or_words_is_the_or_of_the_words_read_one_by_one() {
        let mut mem = [0u8; 4096];
        for (i, b) in mem.iter_mut().enumerate() {
            *b = if i % 97 == 0 { (i / 97) as u8 } else { 0 };
        }
        let mut copy = mem;
        for (off, n, stride) in [(0, 0, 4), (0, 10, 4), (388, 7, 4), (4, 5, 512), (0, 8, 512)] {
            let fold = (0..n).fold(0, |a, k| {
                a | ArrayBus::new(&mut mem).read_u32(off + k * stride)
            });
            assert_eq!(ArrayBus::new(&mut mem).or_words(off, n, stride), fold);
            assert_eq!(
                Plain(ArrayBus::new(&mut copy)).or_words(off, n, stride),
                fold
            );
        }
    }

    #[test]
    fn nonzero_bits_marks_the_nonzero_words() {
        let mut mem = [0u8; 4096];
        for (i, b) in mem.iter_mut().enumerate() {
            *b = if i % 37 == 0 { 1 + (i % 251) as u8 } else { 0 };
        }
        let mut copy = mem;
        for off in [0, 128, 1000, 3964] {
            let want = (0..32).fold(0, |a, k| {
                a | (((ArrayBus::new(&mut mem).read_u32(off + 4 * k) != 0) as u32) << k)
            });
            assert_eq!(ArrayBus::new(&mut mem).nonzero_bits(off), want);
            assert_eq!(Plain(ArrayBus::new(&mut copy)).nonzero_bits(off), want);
        }
    }

    #[test]
    fn nonzero_bits_strided_marks_the_nonzero_words() {
        let mut mem = [0u8; 0x4000];
        for (i, b) in mem.iter_mut().enumerate() {
            *b = if i % 37 == 0 { 1 + (i % 251) as u8 } else { 0 };
        }
        let mut copy = mem;
        for (off, n, stride) in [
            (0, 32, 512),
            (128, 7, 512),
            (1000, 32, 4),
            (3964, 1, 8),
            (0, 0, 4),
        ] {
            let want = (0..n).fold(0, |a, k| {
                a | (((ArrayBus::new(&mut mem).read_u32(off + stride * k) != 0) as u32) << k)
            });
            assert_eq!(
                ArrayBus::new(&mut mem).nonzero_bits_strided(off, n, stride),
                want
            );
            assert_eq!(
                Plain(ArrayBus::new(&mut copy)).nonzero_bits_strided(off, n, stride),
                want
            );
        }
        // Not all zero, not all marked.
        let w = ArrayBus::new(&mut mem).nonzero_bits_strided(0, 32, 512);
        assert!(w != 0 && w != u32::MAX, "{w:#x}");
    }

    #[test]
    fn count_column_updates_the_plain_words_and_stops_before_the_first_other() {
        use crate::layout::{counter_fast, cspace_counter};
        let mut mem = [0u8; 0x2_0000];
        let col = cspace_counter(3, 0, 0);
        let at = |r: u32| cspace_counter(3, r, 0);
        // Rows 126, 127, 0, 1, 2 (wrapping): plain words, then one with a byte at 128.
        let words = [
            0x0101_0101u32,
            0x0203_0405,
            0x7F00_0001,
            0x0080_0000,
            0x0101_0101,
        ];
        let rows = [126u32, 127, 0, 1, 2];
        for (r, w) in rows.iter().zip(words) {
            ArrayBus::new(&mut mem).write_u32(at(*r), w);
        }
        let all = 0x0101_0101;
        // Two pieces: two rows with every counter, three with the low one only.
        let pieces = [2, all, 3, 0x0000_0001, 0, 0, 0, 0, 0, 0];
        let mut bus = ArrayBus::new(&mut mem);
        assert_eq!(
            bus.count_column(col, 126, &pieces, 0, false),
            3,
            "stops at row 1"
        );
        assert_eq!(bus.read_u32(at(126)), 0x0202_0202);
        assert_eq!(bus.read_u32(at(127)), 0x0304_0506);
        assert_eq!(
            bus.read_u32(at(0)),
            0x7F00_0002,
            "past the seam, the second piece's mask"
        );
        assert_eq!(
            bus.read_u32(at(1)),
            0x0080_0000,
            "the stopping word is untouched"
        );
        assert_eq!(bus.read_u32(at(2)), 0x0101_0101);
        // Going on after it, as the raster does once it has done that word byte by byte.
        assert_eq!(bus.count_column(col, 126, &pieces, 4, false), 5);
        assert_eq!(bus.read_u32(at(2)), 0x0101_0102);
        assert_eq!(bus.read_u32(at(126)), 0x0202_0202, "passed over");
        // Down: a selected counter at zero stops it.
        bus.write_u32(at(127), 0x0100_0101);
        assert_eq!(bus.count_column(col, 126, &pieces, 0, true), 1);
        assert_eq!(bus.read_u32(at(126)), 0x0101_0101);
        assert!(!counter_fast(0x0100_0101, all, true));
        // The trait's own loop on a bus with only the required methods does the same.
        let mut copy = [0u8; 0x2_0000];
        for (r, w) in rows.iter().zip(words) {
            ArrayBus::new(&mut copy).write_u32(at(*r), w);
        }
        assert_eq!(
            Plain(ArrayBus::new(&mut copy)).count_column(col, 126, &pieces, 0, false),
            3
        );
    }

    #[test]
    fn count_run_updates_the_plain_words_and_stops_before_the_first_other() {
        use crate::layout::cspace_counter;
        let mut mem = [0u8; 0x2_0000];
        let col = cspace_counter(5, 0, 0);
        let at = |r: u32| cspace_counter(5, r, 0);
        let rows = [126u32, 127, 0, 1];
        let words = [0x0101_0101u32, 0x7F00_0001, 0x0203_0405, 0x0080_0000];
        for (r, w) in rows.iter().zip(words) {
            ArrayBus::new(&mut mem).write_u32(at(*r), w);
        }
        let mut bus = ArrayBus::new(&mut mem);
        // Up from row 126 (given unwrapped: 254), across the seam, stopping at row 1.
        assert_eq!(bus.count_run(col, 254, 4, 0x0100_0001, false), 3);
        assert_eq!(bus.read_u32(at(126)), 0x0201_0102);
        assert_eq!(bus.read_u32(at(127)), 0x8000_0002, "a byte may reach 128");
        assert_eq!(bus.read_u32(at(0)), 0x0303_0406, "past the seam");
        assert_eq!(
            bus.read_u32(at(1)),
            0x0080_0000,
            "the stopping word is untouched"
        );
        // Row 127 now has a byte at 128: a run from it stops at once; one that ends before
        // it runs whole.
        assert_eq!(bus.count_run(col, 127, 2, 0x0000_0001, false), 0);
        assert_eq!(bus.count_run(col, 126, 1, 0x0000_0001, false), 1);
        assert_eq!(bus.count_run(col, 126, 0, 0x0000_0001, false), 0);
        // Down: a selected counter at zero stops it, an unselected one does not.
        assert_eq!(bus.count_run(col, 0, 1, 0x0001_0000, true), 1);
        assert_eq!(bus.read_u32(at(0)), 0x0302_0406);
        bus.write_u32(at(2), 0x0100_0000);
        assert_eq!(bus.count_run(col, 2, 1, 0x0000_0001, true), 0);
        assert_eq!(bus.read_u32(at(2)), 0x0100_0000);
        // The trait's own loop on a bus with only the required methods does the same.
        let mut copy = [0u8; 0x2_0000];
        for (r, w) in rows.iter().zip(words) {
            ArrayBus::new(&mut copy).write_u32(at(*r), w);
        }
        assert_eq!(
            Plain(ArrayBus::new(&mut copy)).count_run(col, 254, 4, 0x0100_0001, false),
            3
        );
    }
}
