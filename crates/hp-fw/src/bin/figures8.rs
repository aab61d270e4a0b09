//! The figures build for an 8x8 (eight corners), see `hp_fw::figures`.
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::figures::main::<8>(&hp_ctrl::calibration::SEED_8)
}
