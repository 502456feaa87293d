//! Assembles `asm/rt.S` and `asm/servo.S` with GNU as for the 68020 images and links them
//! whole-archive, so the vector table and reset code are always part of the image (the
//! linker's section garbage collection drops the routines a board does not call).
use std::path::PathBuf;
use std::process::Command;

fn run(cmd: &mut Command) {
    let shown = format!("{cmd:?}");
    let st = cmd.status().unwrap_or_else(|e| {
        panic!("cannot run {shown}: {e} (install Debian's binutils-m68k-linux-gnu)")
    });
    assert!(st.success(), "{shown} failed: {st}");
}

fn main() {
    const SOURCES: [&str; 2] = ["rt", "servo"];
    for s in SOURCES {
        println!("cargo:rerun-if-changed=asm/{s}.S");
    }
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("m68k") {
        return;
    }
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let lib = out.join("librtasm.a");
    let _ = std::fs::remove_file(&lib);
    for s in SOURCES {
        let obj = out.join(format!("{s}.o"));
        run(Command::new("m68k-linux-gnu-as")
            .args(["-m68020", "-o"])
            .arg(&obj)
            .arg(format!("asm/{s}.S")));
        run(Command::new("m68k-linux-gnu-ar")
            .arg("crs")
            .arg(&lib)
            .arg(&obj));
    }
    println!("cargo:rustc-link-search=native={}", out.display());
    println!("cargo:rustc-link-lib=static:+whole-archive=rtasm");
}
