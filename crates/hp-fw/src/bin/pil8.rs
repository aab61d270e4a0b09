//! The lock-step processor-in-the-loop firmware for an 8x8: as
//! `hp-fw-pil`, with eight corners (calibration `PIL_8`).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::mps2::main::<8>(&hp_ctrl::calibration::PIL_8, hp_fw::run::Timing::LockStep)
}
