use hp_core::{motion::Motion, presets, rig::*, unit::*};
fn main() {
    let unit = Unit::new(presets::seed_unit()).unwrap();
    for (hard, on) in [(true, false), (true, true), (false, false), (false, true)] {
        let v = Valves::from_modes(hard, on);
        let kind = RigKind::Sdof { sprung_mass_kg: 3000.0, base: Motion::Step { height_m: 0.043, start_s: 0.5, rise_s: 0.05 } };
        let rig = Rig::new(&unit, kind, 293.15, v).unwrap();
        let times: Vec<f64> = (0..=6000).map(|i| i as f64 * 1e-3).collect();
        let mut z = vec![]; let mut pmax: f64 = 0.0; let mut ed = 0.0;
        run(&rig, times.iter().copied(), 1e-3, |_, _| v, |_, s| { z.push(s.body_disp_m); pmax = pmax.max(s.unit.p_small_pa); ed = s.e_damper_j; true }).unwrap();
        // crossings of z - 0.043 (upwards and downwards) after the step
        let mut cross = vec![];
        for i in 600..z.len()-1 { let a = z[i]-0.043; let b = z[i+1]-0.043; if a.signum()!=b.signum() && a!=0.0 { cross.push(times[i] + 1e-3*a/(a-b)); } }
        let peak = z.iter().cloned().fold(f64::MIN, f64::max);
        let tpk = times[z.iter().position(|&x| x==peak).unwrap()];
        println!("hard={hard} on={on}: static_disp={:.4} peak={:.4} t_peak={:.3} crossings={:?} pmax={:.2}MPa Ed={:.0}J", rig.static_disp_m(), peak, tpk, &cross[..cross.len().min(6)], pmax/1e6, ed);
        if cross.len()>=3 { println!("   f from crossings = {:.3} Hz", 1.0/(cross[2]-cross[0])); }
        println!("   f from first peak = {:.3} Hz", 1.0/(2.0*(tpk-0.525)));
    }
}
