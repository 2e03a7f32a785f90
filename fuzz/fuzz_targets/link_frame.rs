//! The machine link's frame decoder and server (REQ-LINK-01, REQ-LINK-02). The whole input is
//! decoded as a frame and streamed through a deframer (totality, canonical re-encoding);
//! then its first byte picks the machine's state kind, the second how many garbage bytes
//! precede each request, and the rest gives the garbage and the requests' postcard payloads,
//! served to a machine in that state: it must stay in its state, keep its record outside
//! Ready, and command the drive in the ticks after as an unserved copy does
//! (`taut_proofs::link::check_input`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use taut_proofs::link::check_input;

fuzz_target!(|data: &[u8]| {
    check_input(data);
});
