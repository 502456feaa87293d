//! Links a board binary with the board memory map in `linker/board.ld` (shared by every
//! board package as its build script).
fn main() {
    let dir = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let script = std::path::Path::new(&dir).join("../../linker/board.ld");
    println!("cargo:rerun-if-changed={}", script.display());
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("m68k") {
        println!("cargo:rustc-link-arg-bins=-T{}", script.display());
    }
}
