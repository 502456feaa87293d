//! The command line as a user meets it: output into a pipe whose reader has gone.

use std::process::{Command, Stdio};

/// `sim-host run ... | head -1`: the reader closes the pipe and the program ends quietly
/// with 141 (128 + SIGPIPE, what a shell reports for a program a closed pipe ended), no
/// panic, no backtrace. The pipe here is closed before the first line, so every line fails.
#[test]
fn a_closed_stdout_ends_the_program_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out_dir = std::env::temp_dir().join(format!("sim-host-cli-{}", std::process::id()));
    let scenario = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/fig_vi_3_free.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", scenario, "--out"])
        .arg(&out_dir)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out_dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
}

/// `--icache` on a command that runs no image is refused with the reason, not ignored.
#[test]
fn icache_without_an_image_is_refused() {
    let scenario = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/fig_vi_3_free.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["--icache", "run", scenario, "--mode", "native"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains("runs no image"), "stderr: {stderr}");
}
