//! Logging: the firmware's only contact with defmt.
//!
//! On the microcontroller the macros forward to defmt, which sends compact binary frames over
//! RTT to the debug probe (`probe-rs run` decodes them). On the host they compile to nothing,
//! so the hardware-independent modules can log without a defmt global logger being linked
//! into the test binaries. Keeping this in one module (Embassy's `fmt.rs` pattern) means no
//! other file names defmt, and swapping the transport is a change here only.

/// Logs an informational event (defmt `info!` on the target, nothing on the host).
#[macro_export]
macro_rules! info {
    ($($arg:tt)*) => {{
        #[cfg(target_os = "none")]
        ::defmt::info!($($arg)*);
    }};
}

/// Logs a warning (defmt `warn!` on the target, nothing on the host).
#[macro_export]
macro_rules! warn {
    ($($arg:tt)*) => {{
        #[cfg(target_os = "none")]
        ::defmt::warn!($($arg)*);
    }};
}

/// Logs an error (defmt `error!` on the target, nothing on the host).
#[macro_export]
macro_rules! error {
    ($($arg:tt)*) => {{
        #[cfg(target_os = "none")]
        ::defmt::error!($($arg)*);
    }};
}
