//! The typed layout of the VME global RAM (design.md sections 4 and 5).
//!
//! In the thesis (ch. II section 4, "Computing", thesis lines ~480-503) five 68020 boards
//! run asynchronously and communicate only through an 8 MB global RAM board on the VME
//! backplane. This crate is the one source of truth for that RAM: every record, its offset,
//! its size, its single writer, and the protocol used to publish it.
//!
//! * [`bus`]: the [`GlobalBus`] trait through which every board reaches global RAM (volatile
//!   MMIO on the real board, a byte array in tests and in the simulator).
//! * [`mod@record`]: fixed-size records of 32-bit words published under a sequence lock.
//! * [`layout`]: the offsets, asserted at compile time, and the table `docs/memory-map.md`
//!   is checked against.
//! * [`board`]: board identities, heartbeats, status words and fault records.
//! * [`records`]: the records of every data flow.
//! * [`log`]: the per-board log ring the host decodes.
//!
//! Global RAM is big-endian, like the 68020; offsets here are relative to
//! [`GLOBAL_RAM_BASE`] as the boards see it.
#![no_std]
#![deny(missing_docs)]

pub mod board;
pub mod bus;
pub mod layout;
pub mod log;
pub mod record;
pub mod records;

pub use board::{BoardId, BoardState, FaultCode, FaultRecord, HostAction, Lifecycle, StatusWord};
pub use bus::{ArrayBus, GlobalBus};
pub use layout::*;
pub use record::{Record, SeqLock, Torn};

/// Address of global RAM on every board's bus (design.md section 4).
pub const GLOBAL_RAM_BASE: u32 = 0x0100_0000;
/// Size of global RAM: 8 MiB.
pub const GLOBAL_RAM_SIZE: u32 = 0x0080_0000;
