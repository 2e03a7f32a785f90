//! taut-firmware (under construction): links taut-core.
#![no_std]
#![no_main]
