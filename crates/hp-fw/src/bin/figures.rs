//! The figures build for a 4x4 (four corners), see `hp_fw::figures`.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::figures::main::<4>(&hp_ctrl::calibration::SEED_4)
}
