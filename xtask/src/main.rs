//! `cargo xtask`: the project's build tasks (design.md section 8).
//!
//! * `cargo xtask images [--out DIR]`: builds the five board images for the 68020 and writes
//!   `<board>.elf`, `<board>.s19` (Motorola S-record) and `<board>.bin` (raw, loaded at 0)
//!   to `target/images/` (or DIR), checks that each S-record and binary load back to the same
//!   bytes as the ELF, and prints a size table against the 1 MiB of local RAM.
//! * `cargo xtask docs`: rewrites the generated tables of `docs/memory-map.md` and
//!   `docs/registers.md` from the code.
//! * `cargo xtask test`: images, then formatting, clippy and every test of the workspace.

mod ccr;

use sim_host::image::{Image, LOCAL_RAM_SIZE};
use sim_host::IMAGE_NAMES;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Firmware target triple.
const TARGET: &str = "m68k-unknown-none-elf";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .expect("workspace root")
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

fn run(mut c: Command) -> Result<(), String> {
    let shown = format!("{c:?}");
    let st = c.status().map_err(|e| format!("cannot run {shown}: {e}"))?;
    if st.success() {
        Ok(())
    } else {
        Err(format!("failed ({st}): {shown}"))
    }
}

fn images(out: &Path) -> Result<(), String> {
    let mut c = cargo();
    c.args(["build", "--release", "--target", TARGET])
        .args(["-Zbuild-std=core,compiler_builtins"]);
    for b in IMAGE_NAMES {
        c.args([
            "-p",
            &format!("board-{b}"),
            "--features",
            &format!("board-{b}/image"),
        ]);
    }
    run(c)?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    // Where cargo put them: CARGO_TARGET_DIR when set (relative to the workspace), else
    // `target/`.
    let target_dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(|d| root().join(d))
        .unwrap_or_else(|| root().join("target"));
    let built = target_dir.join(TARGET).join("release");
    println!(
        "{:<8} {:>8} {:>8} {:>8} {:>9} {:>7}  files",
        "board", "text", "data", "bss", "total", "of 1MiB"
    );
    for b in IMAGE_NAMES {
        let elf = out.join(format!("{b}.elf"));
        std::fs::copy(built.join(b), &elf).map_err(|e| format!("copy {b}: {e}"))?;
        for (fmt, ext) in [("srec", "s19"), ("binary", "bin")] {
            let mut c = Command::new("m68k-linux-gnu-objcopy");
            c.args(["-O", fmt]);
            if fmt == "srec" {
                c.arg("--srec-forceS3");
            }
            c.arg(&elf).arg(out.join(format!("{b}.{ext}")));
            run(c).map_err(|e| format!("{e}\n(is binutils-m68k-linux-gnu installed?)"))?;
        }
        check_ccr(&elf)?;
        let img = Image::load(&elf).map_err(|e| e.to_string())?;
        for ext in ["s19", "bin"] {
            let other = Image::load(&out.join(format!("{b}.{ext}"))).map_err(|e| e.to_string())?;
            if other.to_ram() != img.to_ram() {
                return Err(format!(
                    "{b}.{ext} does not load to the same bytes as {b}.elf"
                ));
            }
        }
        let s = img.sizes.unwrap_or_default();
        let total = s.text + s.data + s.bss;
        println!(
            "{:<8} {:>8} {:>8} {:>8} {:>9} {:>6.2}%  {b}.elf {b}.s19 {b}.bin",
            b,
            s.text,
            s.data,
            s.bss,
            total,
            100.0 * total as f64 / LOCAL_RAM_SIZE as f64
        );
    }
    println!("wrote {} files to {}", 3 * IMAGE_NAMES.len(), out.display());
    Ok(())
}

/// Rewrites the generated tables of `docs/memory-map.md` and `docs/registers.md`.
fn docs() -> Result<(), String> {
    for (name, block) in [
        ("memory-map.md", sim_host::docs::memory_map()),
        ("registers.md", sim_host::docs::registers()),
    ] {
        let path = root().join("docs").join(name);
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let new = sim_host::docs::splice(&text, &block)
            .ok_or_else(|| format!("{}: no generated-block markers", path.display()))?;
        std::fs::write(&path, new).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Refuses an image with the CCR-clobber miscompile outside code it never executes.
fn check_ccr(elf: &Path) -> Result<(), String> {
    let out = Command::new("m68k-linux-gnu-objdump")
        .args(["-d", "--no-show-raw-insn"])
        .arg(elf)
        .output()
        .map_err(|e| {
            format!("cannot run m68k-linux-gnu-objdump: {e} (install binutils-m68k-linux-gnu)")
        })?;
    if !out.status.success() {
        return Err(format!(
            "m68k-linux-gnu-objdump failed on {}",
            elf.display()
        ));
    }
    let hits = ccr::scan(&String::from_utf8_lossy(&out.stdout));
    let fatal: Vec<_> = hits.iter().filter(|h| !ccr::tolerated(h)).collect();
    if fatal.is_empty() {
        return Ok(());
    }
    let mut msg = format!(
        "{}: LLVM M68k miscompile ({} sites; docs/toolchain.md):",
        elf.display(),
        fatal.len()
    );
    for h in fatal {
        msg += &format!(
            "\n  {:#07x} in {}: `{}` before `{}`",
            h.branch_addr, h.function, h.clobber, h.branch
        );
    }
    Err(msg)
}

fn test() -> Result<(), String> {
    images(&root().join("target/images"))?;
    let mut c = cargo();
    c.args(["fmt", "--all", "--check"]);
    run(c)?;
    let mut c = cargo();
    c.args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]);
    run(c)?;
    let mut c = cargo();
    c.args(["test", "--workspace"])
        .stdout(std::process::Stdio::piped());
    let mut child = c
        .spawn()
        .map_err(|e| format!("cannot run cargo test: {e}"))?;
    let (mut passed, mut failed) = (0u64, 0u64);
    let stdout = child.stdout.take().expect("piped");
    for line in std::io::BufRead::lines(std::io::BufReader::new(stdout)) {
        let line = line.map_err(|e| e.to_string())?;
        println!("{line}");
        if let Some(rest) = line.strip_prefix("test result: ") {
            let count = |word: &str| -> u64 {
                rest.split(';')
                    .find_map(|p| {
                        p.trim().strip_suffix(word).map(|n| {
                            n.trim()
                                .trim_start_matches("ok.")
                                .trim_start_matches("FAILED.")
                                .trim()
                                .parse()
                                .unwrap_or(0)
                        })
                    })
                    .unwrap_or(0)
            };
            passed += count(" passed");
            failed += count(" failed");
        }
    }
    let st = child.wait().map_err(|e| e.to_string())?;
    // One closing line for the whole workspace (cargo's last line is often an empty doc-test run).
    println!("workspace: {passed} passed, {failed} failed");
    if st.success() && failed == 0 {
        Ok(())
    } else {
        Err(format!("cargo test failed ({st})"))
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let r = match args.first().map(String::as_str) {
        Some("images") => {
            let out = match args.get(1).map(String::as_str) {
                Some("--out") => match args.get(2) {
                    Some(d) => PathBuf::from(d),
                    None => {
                        eprintln!("xtask: --out needs a directory");
                        return ExitCode::from(2);
                    }
                },
                Some(other) => {
                    eprintln!("xtask: unknown argument {other:?}");
                    return ExitCode::from(2);
                }
                None => root().join("target/images"),
            };
            images(&out)
        }
        Some("test") => test(),
        Some("docs") => docs(),
        _ => {
            eprintln!(
                "usage: cargo xtask images [--out DIR] | cargo xtask docs | cargo xtask test"
            );
            return ExitCode::from(2);
        }
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
