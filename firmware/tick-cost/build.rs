//! Build script: links the replay for QEMU's `mps2-an386` (a Cortex-M4), and nothing on the
//! host.
//!
//! For a target without an operating system it places `memory.x` (the board's memory map)
//! where cortex-m-rt's `link.x` finds it, and links the binaries with `link.x`. The session
//! the replay embeds is named by `TAUT_TICK_COST_SESSION` (set by `scripts/tick-cost`).

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=TAUT_TICK_COST_SESSION");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) else {
        println!("cargo:warning=OUT_DIR is not set; cannot place memory.x");
        return;
    };
    if let Err(error) = fs::copy("memory.x", out.join("memory.x")) {
        println!("cargo:warning=cannot copy memory.x: {error}");
        return;
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
