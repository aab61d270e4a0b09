//! The ECU firmware on an STM32F405 with bxCAN1 (compile-checked in CI;
//! flash with any SWD probe, e.g. `probe-rs run --chip STM32F405RGTx`).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::stm32f4::main()
}
