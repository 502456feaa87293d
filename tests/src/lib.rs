//! Shared helpers of the system tests.
#![deny(missing_docs)]

use sim_host::emu::EmuBoard;
use sim_host::image::Image;
use std::path::PathBuf;
use vme_map::{BoardId, GLOBAL_RAM_SIZE};

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

/// Board `id`'s image on an emulated 68020 with its standalone devices, for calling its
/// functions one at a time (`EmuBoard::call`): the board, its image (for symbols) and an
/// empty global RAM.
pub fn board_of(id: BoardId) -> (EmuBoard, Image, Vec<u8>) {
    let img =
        Image::load(&images_dir().join(format!("{}.elf", sim_host::boot::image_name(id)))).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let b = EmuBoard::new(id, &img, sim_host::devices::standalone(id), &mut global);
    (b, img, global)
}
