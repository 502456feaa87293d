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
        Self { ring: log_ring(board) }
    }

    fn push(&self, bus: &mut dyn GlobalBus, kind: Kind, arg: u32, heartbeat: u32, text: &[u8]) {
        let n = bus.read_u32(self.ring);
        let e = self.ring + LOG_ENTRIES_OFFSET + (n % LOG_ENTRIES) * LOG_ENTRY_BYTES;
        // Invalidate first so a reader never pairs an old sequence with new contents.
        bus.write_u32(e, 0);
        let len = text.len().min(PAYLOAD_BYTES);
        bus.write_u32(e + 4, (kind as u32) << 24 | len as u32);
        bus.write_u32(e + 8, heartbeat);
        bus.write_u32(e + 12, arg);
        let mut buf = [0u8; PAYLOAD_BYTES];
        buf[..len].copy_from_slice(&text[..len]);
        for i in 0..PAYLOAD_BYTES / 4 {
            let w = u32::from_be_bytes([buf[4 * i], buf[4 * i + 1], buf[4 * i + 2], buf[4 * i + 3]]);
            bus.write_u32(e + 16 + 4 * i as u32, w);
        }
        bus.write_u32(e, n.wrapping_add(1));
        bus.write_u32(self.ring, n.wrapping_add(1));
    }

    /// Logs an event code with an argument.
    pub fn event(&self, bus: &mut dyn GlobalBus, heartbeat: u32, code: u32) {
        self.push(bus, Kind::Event, code, heartbeat, &[]);
    }

    /// Logs `text`, split over as many entries as it needs (at most the ring's size).
    pub fn text(&self, bus: &mut dyn GlobalBus, heartbeat: u32, text: &[u8]) {
        let mut chunks = text.chunks(PAYLOAD_BYTES).take(LOG_ENTRIES as usize).peekable();
        if chunks.peek().is_none() {
            self.push(bus, Kind::TextEnd, 0, heartbeat, &[]);
        }
        while let Some(c) = chunks.next() {
            let kind = if chunks.peek().is_some() { Kind::Text } else { Kind::TextEnd };
            self.push(bus, kind, 0, heartbeat, c);
        }
    }
}

/// A [`core::fmt::Write`] sink that streams formatted text into a log ring, for panic
/// messages: it needs no buffer beyond one entry.
pub struct LogFmt<'a> {
    writer: LogWriter,
    bus: &'a mut dyn GlobalBus,
    heartbeat: u32,
    buf: [u8; PAYLOAD_BYTES],
    len: usize,
}

impl<'a> LogFmt<'a> {
    /// A sink writing to `board`'s ring.
    pub fn new(board: BoardId, bus: &'a mut dyn GlobalBus, heartbeat: u32) -> Self {
        Self { writer: LogWriter::new(board), bus, heartbeat, buf: [0; PAYLOAD_BYTES], len: 0 }
    }

    /// Writes the last fragment as a [`Kind::TextEnd`] entry.
    pub fn finish(mut self) {
        let len = self.len;
        self.writer.push(self.bus, Kind::TextEnd, 0, self.heartbeat, &self.buf[..len]);
        self.len = 0;
    }
}

impl core::fmt::Write for LogFmt<'_> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &b in s.as_bytes() {
            if self.len == PAYLOAD_BYTES {
                self.writer.push(self.bus, Kind::Text, 0, self.heartbeat, &self.buf);
                self.len = 0;
            }
            self.buf[self.len] = b;
            self.len += 1;
        }
        Ok(())
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
        let Some(kind) = Kind::from_u8((hdr >> 24) as u8) else { continue };
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
    use core::fmt::Write;

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
    fn formatted_text_spans_entries_and_reassembles() {
        let mut mem = [0u8; 0x2_8000];
        let mut bus = ArrayBus::new(&mut mem);
        let mut w = LogFmt::new(BoardId::Reflex, &mut bus, 7);
        write!(w, "panicked at src/main.rs:12: value {} out of range", 42).unwrap();
        w.finish();
        let (out, len) = collect_text(&mut bus, BoardId::Reflex);
        assert_eq!(&out[..len], b"panicked at src/main.rs:12: value 42 out of range");
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
