//! The fixed-rate loop shared by the boards.

use crate::ecu::{Ecu, Link};

/// How control periods are triggered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timing {
    /// Only by the 1 kHz timer (a real ECU).
    Timer,
    /// By the timer until the first `HP_PilTick` arrives, then only by
    /// ticks: each tick closes exactly one period (processor-in-the-loop).
    TimerOrLockStep,
}

/// Runs the ECU forever. `ticks` reads a counter that the 1 kHz timer
/// interrupt increments; `service` moves bytes between the hardware and
/// the link's queues. Neither may block.
///
/// If the loop ever falls behind the timer, the missed ticks are skipped:
/// one period runs per observed change of the counter.
pub fn run<L: Link>(ecu: &mut Ecu, link: &mut L, ticks: impl Fn() -> u32, service: impl Fn(&mut L), timing: Timing) -> ! {
    let mut done = ticks();
    let mut lock_step = false;
    loop {
        service(link);
        while let Some(frame) = link.receive() {
            if ecu.receive(&frame).is_some() && timing == Timing::TimerOrLockStep {
                lock_step = true;
                ecu.period(link);
                // Frames after the tick belong to the next period.
                break;
            }
        }
        let now = ticks();
        if !lock_step && now != done {
            done = now;
            ecu.period(link);
        }
    }
}
