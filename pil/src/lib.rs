//! taut's processor-in-the-loop bench: the firmware image that ships, run instruction by
//! instruction on an emulated STM32G431 whose peripherals are modelled at register level,
//! closed around taut's digital twin.
pub mod adc;
pub mod bench;
pub mod cycle;
pub mod elf;
pub mod faults;
pub mod gates;
pub mod link;
pub mod mcu;
pub mod panel;
pub mod report;
pub mod rtt;
pub mod soc;
pub mod tim;
pub mod usart;
