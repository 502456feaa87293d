//! Per-board log rings in global RAM, decoded by the host (design.md section 4).
//!
//! Like defmt/RTT, the firmware writes compact fixed-size entries and the host turns them into
//! text. A ring is a write-index word (entries ever written) followed by
//! [`crate::LOG_ENTRIES`] entries of [`crate::LOG_ENTRY_BYTES`]:
//!
//! | word | contents |
//! |---|---|
//! | 0 | sequence number of the entry + 1 (0 = never written); written last |
//! | 1 | bits 24-31 [`Kind`], bits 0-7 payload length in bytes |
//! | 2 | the board's heartbeat when written |
//! | 3 | argument word |
//! | 4-7 | payload: up to 16 bytes of text |
//!
//! Text longer than 16 bytes (a panic message) spans entries of kind [`Kind::Text`] ending
//! with one of kind [`Kind::TextEnd`].

use crate::board::BoardId;
use crate::bus::GlobalBus;
use crate::layout::{log_ring, LOG_ENTRIES, LOG_ENTRIES_OFFSET, LOG_ENTRY_BYTES};

/// Payload bytes per entry.
pub const PAYLOAD_BYTES: usize = 16;

/// What an entry holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// A fragment of text continued in the next entry.
    Text = 1,
    /// The last fragment of a text message.
    TextEnd = 2,
    /// An event code (payload empty; the code is the argument word).
    Event = 3,
}

impl Kind {
    /// The kind for its code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        match v {
            1 => Some(Kind::Text),
            2 => Some(Kind::TextEnd),
            3 => Some(Kind::Event),
            _ => None,
        }
    }
}

/// The writer side of one board's ring. Only that board writes it.
pub struct LogWriter {
    ring: u32,
}

impl LogWriter {
    /// The writer for `board`'s ring.
    pub const fn new(board: BoardId) -> Self {
        Self {
            ring: log_ring(board),
        }
    }

    /// Logs an event code with an argument.
    fn push_event(&self, bus: &mut dyn GlobalBus, arg: u32, heartbeat: u32) {
        let n = bus.read_u32(self.ring);
        let e = self.ring + LOG_ENTRIES_OFFSET + (n % LOG_ENTRIES) * LOG_ENTRY_BYTES;
        bus.write_u32(e, 0);
        bus.write_u32(e + 4, (Kind::Event as u32) << 24);
        bus.write_u32(e + 8, heartbeat);
        bus.write_u32(e + 12, arg);
        for i in 0..(PAYLOAD_BYTES as u32 / 4) {
            bus.write_u32(e + 16 + 4 * i, 0);
        }
        bus.write_u32(e, n.wrapping_add(1));
        bus.write_u32(self.ring, n.wrapping_add(1));
    }

    /// Logs an event code with an argument.
    pub fn event(&self, bus: &mut dyn GlobalBus, heartbeat: u32, code: u32) {
        self.push_event(bus, code, heartbeat);
    }

    /// Logs `text`, split over as many entries as it needs.
    pub fn text(&self, bus: &mut dyn GlobalBus, heartbeat: u32, text: &[u8]) {
        let mut t = TextStream::new(self.ring, bus, heartbeat);
        t.push(bus, text);
        t.finish(bus);
    }
}

/// Text streamed straight into a ring's entries in global RAM, a byte at a time: no local
/// buffer, so the panic handler can use it (LLVM's M68k backend miscompiles some indexed
/// stores into stack buffers; docs/toolchain.md).
pub struct TextStream {
    ring: u32,
    seq: u32,
    fill: u32,
    open: bool,
    heartbeat: u32,
}

impl TextStream {
    fn new(ring: u32, bus: &mut dyn GlobalBus, heartbeat: u32) -> Self {
        Self {
            ring,
            seq: bus.read_u32(ring),
            fill: 0,
            open: false,
            heartbeat,
        }
    }

    /// A stream into `board`'s ring.
    pub fn for_board(board: BoardId, bus: &mut dyn GlobalBus, heartbeat: u32) -> Self {
        Self::new(log_ring(board), bus, heartbeat)
    }

    fn entry(&self) -> u32 {
        self.ring + LOG_ENTRIES_OFFSET + (self.seq % LOG_ENTRIES) * LOG_ENTRY_BYTES
    }

    fn open(&mut self, bus: &mut dyn GlobalBus) {
        let e = self.entry();
        // Invalidate first so a reader never pairs an old sequence with new contents.
        bus.write_u32(e, 0);
        for i in 0..(PAYLOAD_BYTES as u32 / 4) {
            bus.write_u32(e + 16 + 4 * i, 0);
        }
        self.open = true;
        self.fill = 0;
    }

    fn close(&mut self, bus: &mut dyn GlobalBus, kind: Kind) {
        let e = self.entry();
        bus.write_u32(e + 4, (kind as u32) << 24 | self.fill);
        bus.write_u32(e + 8, self.heartbeat);
        bus.write_u32(e + 12, 0);
        let next = self.seq.wrapping_add(1);
        bus.write_u32(e, next);
        bus.write_u32(self.ring, next);
        self.seq = next;
        self.open = false;
        self.fill = 0;
    }

    /// Appends bytes.
    pub fn push(&mut self, bus: &mut dyn GlobalBus, bytes: &[u8]) {
        for &b in bytes {
            if self.open && self.fill == PAYLOAD_BYTES as u32 {
                self.close(bus, Kind::Text);
            }
            if !self.open {
                self.open(bus);
            }
            bus.write_u8(self.entry() + 16 + self.fill, b);
            self.fill += 1;
        }
    }

    /// Appends `v` in decimal.
    pub fn push_decimal(&mut self, bus: &mut dyn GlobalBus, v: u32) {
        // A fixed sequence the compiler unrolls: the loop form of this was miscompiled by
        // LLVM's M68k backend (caught by `cargo xtask images`; docs/toolchain.md).
        const POWERS: [u32; 10] = [
            1_000_000_000,
            100_000_000,
            10_000_000,
            1_000_000,
            100_000,
            10_000,
            1_000,
            100,
            10,
            1,
        ];
        // Digits by repeated subtraction (at most 9 per digit): no division (the M68k backend's DIVU.L clobbers
        // %d0, llvm/llvm-project#224186; docs/toolchain.md).
        let mut started = false;
        let mut rest = v;
        for p in POWERS {
            let mut d = 0u8;
            while rest >= p {
                // The volatile read keeps LLVM from turning the loop back into a divide.
                // SAFETY: a read of a local variable.
                rest = unsafe { core::ptr::read_volatile(&rest) } - p;
                d += 1;
            }
            started |= d != 0 || p == 1;
            if started {
                self.push(bus, &[b'0' + d]);
            }
        }
    }

    /// Ends the message (an empty message is one empty final entry).
    pub fn finish(mut self, bus: &mut dyn GlobalBus) {
        if !self.open {
            self.open(bus);
        }
        self.close(bus, Kind::TextEnd);
    }
}

/// One decoded entry, as the host reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Sequence number of the entry (0-based, increasing).
    pub seq: u32,
    /// What it holds.
    pub kind: Kind,
    /// Heartbeat when written.
    pub heartbeat: u32,
    /// Argument word.
    pub arg: u32,
    /// Payload length.
    pub len: usize,
    /// Payload bytes.
    pub payload: [u8; PAYLOAD_BYTES],
}

/// Reads the entries of `board`'s ring from sequence number `from` on, oldest first, and
/// hands each complete one to `f`. Entries overwritten before they were read are skipped;
/// returns the sequence number to continue from.
pub fn read_entries(
    bus: &mut dyn GlobalBus,
    board: BoardId,
    from: u32,
    f: &mut dyn FnMut(Entry),
) -> u32 {
    let ring = log_ring(board);
    let n = bus.read_u32(ring);
    let start = from.max(n.saturating_sub(LOG_ENTRIES));
    for seq in start..n {
        let e = ring + LOG_ENTRIES_OFFSET + (seq % LOG_ENTRIES) * LOG_ENTRY_BYTES;
        if bus.read_u32(e) != seq.wrapping_add(1) {
            continue; // being rewritten
        }
        let hdr = bus.read_u32(e + 4);
        let Some(kind) = Kind::from_u8((hdr >> 24) as u8) else {
            continue;
        };
        let mut payload = [0u8; PAYLOAD_BYTES];
        for i in 0..PAYLOAD_BYTES / 4 {
            let w = bus.read_u32(e + 16 + 4 * i as u32).to_be_bytes();
            payload[4 * i..4 * i + 4].copy_from_slice(&w);
        }
        f(Entry {
            seq,
            kind,
            heartbeat: bus.read_u32(e + 8),
            arg: bus.read_u32(e + 12),
            len: ((hdr & 0xFF) as usize).min(PAYLOAD_BYTES),
            payload,
        });
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::ArrayBus;

    fn collect_text(bus: &mut dyn GlobalBus, board: BoardId) -> ([u8; 1024], usize) {
        let mut out = [0u8; 1024];
        let mut len = 0;
        read_entries(bus, board, 0, &mut |e| {
            if e.kind != Kind::Event {
                out[len..len + e.len].copy_from_slice(&e.payload[..e.len]);
                len += e.len;
            }
        });
        (out, len)
    }

    #[test]
    fn text_spans_entries_and_reassembles() {
        let mut mem = [0u8; 0x2_8000];
        let mut bus = ArrayBus::new(&mut mem);
        let w = LogWriter::new(BoardId::Reflex);
        let msg = b"panic: value out of range at src/main.rs:12";
        w.text(&mut bus, 7, msg);
        let mut kinds = [Kind::Event; 4];
        let mut n = 0;
        read_entries(&mut bus, BoardId::Reflex, 0, &mut |e| {
            kinds[n] = e.kind;
            n += 1;
        });
        assert_eq!(&kinds[..n], &[Kind::Text, Kind::Text, Kind::TextEnd]);
        let (out, len) = collect_text(&mut bus, BoardId::Reflex);
        assert_eq!(&out[..len], msg);
        // An empty message is one empty final entry; exactly 16 bytes is one entry.
        w.text(&mut bus, 8, b"");
        w.text(&mut bus, 8, &[b'x'; PAYLOAD_BYTES]);
        assert_eq!(read_entries(&mut bus, BoardId::Reflex, 0, &mut |_| {}), 5);
        let mut t = TextStream::for_board(BoardId::Planner, &mut bus, 1);
        t.push(&mut bus, b"line ");
        t.push_decimal(&mut bus, 0);
        t.push(&mut bus, b" ");
        t.push_decimal(&mut bus, 4_294_967_295);
        t.push(&mut bus, b" ");
        t.push_decimal(&mut bus, 1000);
        t.finish(&mut bus);
        let (out, len) = collect_text(&mut bus, BoardId::Planner);
        assert_eq!(&out[..len], b"line 0 4294967295 1000");
        // Other rings untouched.
        assert_eq!(collect_text(&mut bus, BoardId::Servo).1, 0);
    }

    #[test]
    fn overwritten_entries_are_skipped_and_the_newest_kept() {
        let mut mem = [0u8; 0x2_8000];
        let mut bus = ArrayBus::new(&mut mem);
        let w = LogWriter::new(BoardId::Servo);
        for i in 0..(LOG_ENTRIES + 10) {
            w.event(&mut bus, i, 100 + i);
        }
        let mut args = [0u32; 128];
        let mut k = 0;
        let next = read_entries(&mut bus, BoardId::Servo, 0, &mut |e| {
            args[k] = e.arg;
            k += 1;
        });
        assert_eq!(next, LOG_ENTRIES + 10);
        assert_eq!(k, LOG_ENTRIES as usize);
        assert_eq!(args[0], 110);
        assert_eq!(args[k - 1], 100 + LOG_ENTRIES + 9);
    }
}
