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
    std::fs::write(out.join("sqrt_table.s"), sqrt_table())
        .expect("cannot write sqrt_table.s in OUT_DIR");
    let lib = out.join("librtasm.a");
    let _ = std::fs::remove_file(&lib);
    for s in SOURCES {
        let obj = out.join(format!("{s}.o"));
        run(Command::new("m68k-linux-gnu-as")
            .arg("-m68020")
            .arg("-I")
            .arg(&out)
            .arg("-o")
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

/// The square root's table for `SQRT_Q16` in asm/servo.S: `.long` lines of
/// T[i] = floor(2^19 sqrt(i)) = floor(sqrt(i 2^38)), i = 256..=1024, exact in integers.
fn sqrt_table() -> String {
    let mut s = String::new();
    let t: Vec<u64> = (256u64..=1024)
        .map(|i| {
            let n = i << 38;
            let mut r = (n as f64).sqrt() as u64;
            while r * r > n {
                r -= 1;
            }
            while (r + 1) * (r + 1) <= n {
                r += 1;
            }
            r
        })
        .collect();
    for row in t.chunks(8) {
        let v: Vec<String> = row.iter().map(|r| r.to_string()).collect();
        s += &format!("    .long   {}\n", v.join(", "));
    }
    s
}
