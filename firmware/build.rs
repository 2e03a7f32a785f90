//! Build script: links the image for the microcontroller, and nothing on the host.
//!
//! When the target has no operating system (`thumbv7em-none-eabihf`), the image needs
//! cortex-m-rt's `link.x` (which includes `memory.x`) and defmt's `defmt.x`. They are added
//! here rather than in `.cargo/config.toml` so that building from the repository root with
//! `--target thumbv7em-none-eabihf` links exactly like building from inside `firmware/`, while
//! the host build of the workspace is untouched.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
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
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
