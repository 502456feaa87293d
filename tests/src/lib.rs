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
