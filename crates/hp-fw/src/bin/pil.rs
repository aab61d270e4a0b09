//! The ECU firmware on the emulator board for processor-in-the-loop runs:
//! as `hp-fw-mps2` (a 4x4: four corners), but each control period is closed
//! by an `HP_PilTick` frame from the host instead of the timer, from
//! power-on, so the run is deterministic and comparable with the host build
//! period by period. Calibration `PIL_4`: the production one with the
//! gas-charge detector in seconds (`hp_ctrl::calibration`).
#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    hp_fw::mps2::main::<4>(&hp_ctrl::calibration::PIL_4, hp_fw::run::Timing::LockStep)
}
