//! The ECU firmware on the emulator board (QEMU mps2-an386): SLCAN over
//! UART0, control periods on the 1 kHz SysTick.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::mps2::main::<4>(&hp_ctrl::calibration::SEED_4, hp_fw::run::Timing::Timer)
}
