//! The taut-firmware image: an STM32G431 that runs the stringing machine through taut-core.
//!
//! Built for `thumbv7em-none-eabihf`, this is the firmware (see [`hardware`] and
//! `firmware/README.md`). Built for the host — as the workspace's `cargo build`/`cargo test`
//! do — it is a small tool that prints the board's wiring table and flash layout, the two
//! things a person wiring a machine needs from the firmware without a board at hand.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod hardware;

#[cfg(not(target_os = "none"))]
#[allow(clippy::print_stdout, reason = "printing the tables is this host tool's whole job")]
fn main() {
    use taut_firmware::flash_layout::{
        FLASH_BASE, IMAGE_FLASH_KIB, PAGE_SIZE, SETTINGS_PAGES, SETTINGS_RANGE,
    };
    let mut table = String::new();
    if taut_firmware::pins::write_markdown(&mut table).is_err() {
        eprintln!("could not render the wiring table");
        std::process::exit(1);
    }
    println!("taut-firmware: NUCLEO-G431RB + X-NUCLEO-IHM08M1 (build for thumbv7em-none-eabihf");
    println!(
        "to get the image: cargo build -p taut-firmware --release --target thumbv7em-none-eabihf)"
    );
    println!();
    println!("Wiring:");
    println!();
    print!("{table}");
    println!();
    println!(
        "Flash: image in 0x{:08X}..0x{:08X} ({IMAGE_FLASH_KIB} KiB); settings store in \
         0x{:08X}..0x{:08X} ({SETTINGS_PAGES} pages of {PAGE_SIZE} bytes).",
        FLASH_BASE,
        FLASH_BASE.saturating_add(SETTINGS_RANGE.start),
        FLASH_BASE.saturating_add(SETTINGS_RANGE.start),
        FLASH_BASE.saturating_add(SETTINGS_RANGE.end),
    );
}
