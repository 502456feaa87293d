//! Corrupt, truncated, foreign and oversized images are refused with the file and the reason.

use sim_host::image::Image;
use std::path::Path;
use system_tests::images_dir;

fn refusal(name: &str, bytes: &[u8]) -> String {
    Image::parse(Path::new(name), bytes)
        .expect_err("must be refused")
        .to_string()
}

#[test]
fn the_srecord_and_binary_load_the_same_bytes_as_the_elf() {
    let dir = images_dir();
    for b in sim_host::IMAGE_NAMES {
        let elf = Image::load(&dir.join(format!("{b}.elf"))).unwrap();
        let s19 = Image::load(&dir.join(format!("{b}.s19"))).unwrap();
        let bin = Image::load(&dir.join(format!("{b}.bin"))).unwrap();
        assert_eq!(elf.to_ram(), s19.to_ram(), "{b}");
        assert_eq!(elf.to_ram(), bin.to_ram(), "{b}");
    }
}

#[test]
fn a_wrong_architecture_elf_is_refused() {
    let mut elf = std::fs::read(images_dir().join("servo.elf")).unwrap();
    elf[18..20].copy_from_slice(&62u16.to_be_bytes()); // EM_X86_64
    let e = refusal("servo-x86.elf", &elf);
    assert!(e.starts_with("servo-x86.elf: wrong architecture"), "{e}");
    // A host (x86-64) executable: refused before anything is loaded.
    let host = std::fs::read(std::env::current_exe().unwrap()).unwrap();
    let e = refusal("host.elf", &host);
    assert!(e.contains("not a 32-bit ELF"), "{e}");
}

#[test]
fn a_truncated_elf_is_refused() {
    let elf = std::fs::read(images_dir().join("reflex.elf")).unwrap();
    let e = refusal("reflex-cut.elf", &elf[..0x3000]);
    assert!(e.starts_with("reflex-cut.elf: "), "{e}");
}

#[test]
fn a_corrupt_or_truncated_srecord_is_refused_with_its_line() {
    let text = std::fs::read_to_string(images_dir().join("planner.s19")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Truncated: the last third of the file is missing.
    let cut = lines[..lines.len() * 2 / 3].join("\n");
    let e = refusal("planner.s19", cut.as_bytes());
    assert!(e.contains("truncated"), "{e}");
    // One data digit changed on line 10: the checksum no longer matches.
    let mut bad: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    let l = &mut bad[9];
    let pos = 14;
    let c = if &l[pos..pos + 1] == "0" { "1" } else { "0" };
    l.replace_range(pos..pos + 1, c);
    let e = refusal("planner.s19", bad.join("\n").as_bytes());
    assert!(e.starts_with("planner.s19:10: checksum"), "{e}");
}
