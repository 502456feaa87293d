//! Shared helpers of the system tests.
#![deny(missing_docs)]

use std::path::PathBuf;

/// The images directory, or a panic that says how to make it.
pub fn images_dir() -> PathBuf {
    let dir = sim_host::boot::default_images_dir();
    for name in sim_host::IMAGE_NAMES {
        let elf = dir.join(format!("{name}.elf"));
        assert!(
            elf.exists(),
            "{} is missing: build the images first with `cargo xtask images`",
            elf.display()
        );
    }
    dir
}

/// The big-endian word at `addr` of an emulated board's RAM (`EmuBoard::ram`).
pub fn ram_word(ram: &[u8], addr: u32) -> u32 {
    let a = addr as usize;
    u32::from_be_bytes([ram[a], ram[a + 1], ram[a + 2], ram[a + 3]])
}

/// Writes `w` big-endian at `addr` of an emulated board's RAM.
pub fn put_word(ram: &mut [u8], addr: u32, w: u32) {
    ram[addr as usize..addr as usize + 4].copy_from_slice(&w.to_be_bytes());
}
