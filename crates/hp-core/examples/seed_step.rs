//! The seed's SDOF step test on the built-in unit: a 43 mm base step under
//! 3000 kg for the four spring/damper combinations; prints the natural
//! frequency (from the period of the oscillation about the new level), the
//! overshoot and the peak gas pressure.
//!
//!     cargo run --release -p hp-core --example seed_step
use hp_core::motion::Motion;
use hp_core::presets::{seed_unit, SEED_SPRUNG_MASS_KG};
use hp_core::rig::{run, Rig, RigKind};
use hp_core::unit::{Unit, Valves};

const STEP_M: f64 = 0.043;

fn main() -> Result<(), hp_core::Error> {
    let unit = Unit::new(seed_unit())?;
    println!("spring  damper  frequency_hz  overshoot_mm  peak_p_small_mpa");
    for (hard, on) in [(true, false), (true, true), (false, false), (false, true)] {
        let valves = Valves::from_modes(hard, on);
        let kind = RigKind::Sdof {
            sprung_mass_kg: SEED_SPRUNG_MASS_KG,
            base: Motion::Step { height_m: STEP_M, start_s: 0.5, rise_s: 0.05 },
        };
        let rig = Rig::new(&unit, kind, 293.15, valves)?;
        let (mut crossings, mut previous, mut peak_z, mut peak_p) = (Vec::new(), None, f64::MIN, 0.0_f64);
        run(&rig, (0..=6000).map(|i| f64::from(i) * 1e-3), 1e-3, |_, _| valves, |_, s| {
            let above = s.body_disp_m - STEP_M;
            if let Some((t0, a0)) = previous {
                if s.time_s > 0.55 && a0 * above < 0.0 {
                    crossings.push(t0 + (s.time_s - t0) * a0 / (a0 - above));
                }
            }
            previous = Some((s.time_s, above));
            peak_z = peak_z.max(s.body_disp_m);
            peak_p = peak_p.max(s.unit.p_gas_true_pa);
            true
        })?;
        let frequency = match (crossings.first(), crossings.get(2)) {
            (Some(a), Some(b)) => format!("{:.2}", 1.0 / (b - a)),
            _ => "(no oscillation)".to_string(),
        };
        println!(
            "{:<7} {:<7} {frequency:>12}  {:>12.1}  {:>16.1}",
            if hard { "hard" } else { "soft" },
            if on { "on" } else { "off" },
            1e3 * (peak_z - STEP_M).max(0.0),
            peak_p / 1e6
        );
    }
    Ok(())
}
