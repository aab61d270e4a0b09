use hp_core::gas::*;
fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().unwrap()).collect();
    let (rho, t) = (args[0], args[1]);
    for g in Gas::ALL { let p = g.props(rho, t); println!("{} {:?}", g.name(), p); }
}
