//! The FMI 2.0 model description (`modelDescription.xml`) of a model,
//! generated from its variable table so the two cannot drift apart.

use crate::model::{Causality, Kind, ModelInfo, Var};
use std::collections::BTreeSet;
use std::fmt::Write;

/// The SI units the models use: symbol, exponents of (kg, m, s, K), and the
/// display units an importing tool may offer (name, factor, offset: value
/// in the display unit = factor * SI value + offset).
/// A unit: symbol, base-unit exponents, display units.
pub type UnitDef = (&'static str, [i32; 4], &'static [(&'static str, f64, f64)]);

pub const UNITS: &[UnitDef] = &[
    ("m", [0, 1, 0, 0], &[("mm", 1e3, 0.0)]),
    ("m/s", [0, 1, -1, 0], &[("mm/s", 1e3, 0.0)]),
    ("m/s2", [0, 1, -2, 0], &[]),
    ("m2", [0, 2, 0, 0], &[("cm2", 1e4, 0.0)]),
    ("m2/s2", [0, 2, -2, 0], &[]),
    ("Pa/s", [1, -1, -3, 0], &[("bar/s", 1e-5, 0.0)]),
    ("K/s", [0, 0, -1, 1], &[]),
    ("m3", [0, 3, 0, 0], &[("L", 1e3, 0.0)]),
    ("m3/s", [0, 3, -1, 0], &[("L/min", 6e4, 0.0)]),
    ("N", [1, 1, -2, 0], &[("kN", 1e-3, 0.0)]),
    ("N.s/m", [1, 0, -1, 0], &[]),
    ("N/m", [1, 0, -2, 0], &[("N/mm", 1e-3, 0.0)]),
    ("Pa", [1, -1, -2, 0], &[("bar", 1e-5, 0.0), ("MPa", 1e-6, 0.0)]),
    ("Pa.s/m3", [1, -4, -1, 0], &[]),
    ("Pa.s2/m6", [1, -7, 0, 0], &[]),
    ("K", [0, 0, 0, 1], &[("degC", 1.0, -273.15)]),
    ("kg", [1, 0, 0, 0], &[]),
    ("kg/m3", [1, -3, 0, 0], &[]),
    ("s", [0, 0, 1, 0], &[("ms", 1e3, 0.0)]),
    ("W", [1, 2, -3, 0], &[("kW", 1e-3, 0.0)]),
    ("J", [1, 2, -2, 0], &[("kJ", 1e-3, 0.0)]),
    ("rad", [0, 0, 0, 0], &[("deg", 180.0 / core::f64::consts::PI, 0.0)]),
    ("rad/s", [0, 0, -1, 0], &[("deg/s", 180.0 / core::f64::consts::PI, 0.0)]),
];

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A real number as the XML schema's `xs:double` writes it.
fn number(x: f64) -> String {
    if x == f64::INFINITY {
        "INF".into()
    } else if x == f64::NEG_INFINITY {
        "-INF".into()
    } else {
        format!("{x:e}")
    }
}

fn kind_name(k: Kind) -> &'static str {
    match k {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
    }
}

fn variable(out: &mut String, vr: usize, v: &Var) {
    let (causality, variability) = match (v.causality, v.kind) {
        (Causality::Parameter, _) => ("parameter", "fixed"),
        (Causality::Input, Kind::Real) => ("input", "continuous"),
        (Causality::Input, _) => ("input", "discrete"),
        (Causality::Output, Kind::Real) => ("output", "continuous"),
        (Causality::Output, _) => ("output", "discrete"),
    };
    let _ = write!(
        out,
        "    <ScalarVariable name=\"{}\" valueReference=\"{vr}\" causality=\"{causality}\" variability=\"{variability}\"",
        escape(v.name)
    );
    if v.causality == Causality::Output {
        out.push_str(" initial=\"calculated\"");
    }
    let _ = write!(out, " description=\"{}\">\n      <{}", escape(v.description), kind_name(v.kind));
    if let Some(e) = v.enumeration {
        let _ = write!(out, " declaredType=\"{}\"", e.name);
    }
    if !v.unit.is_empty() {
        let _ = write!(out, " unit=\"{}\"", escape(v.unit));
    }
    if v.kind == Kind::Real && !v.min.is_nan() {
        let _ = write!(out, " min=\"{}\"", number(v.min));
    }
    if v.kind == Kind::Real && !v.max.is_nan() {
        let _ = write!(out, " max=\"{}\"", number(v.max));
    }
    if v.causality != Causality::Output {
        let start = match v.kind {
            Kind::Real => number(v.start),
            Kind::Integer => format!("{}", v.start as i64),
            Kind::Boolean => (if v.start != 0.0 { "true" } else { "false" }).into(),
        };
        let _ = write!(out, " start=\"{start}\"");
    }
    out.push_str("/>\n    </ScalarVariable>\n");
}

/// The model description of `info` with `version` as the generating tool's.
pub fn model_description(info: &ModelInfo, version: &str) -> String {
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{id}\" guid=\"{guid}\" description=\"{desc}\" \
         generationTool=\"hp-fmu {version}\" variableNamingConvention=\"structured\" numberOfEventIndicators=\"0\">",
        id = info.identifier,
        guid = info.guid(),
        desc = escape(info.description),
    );
    let _ = writeln!(
        out,
        "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"true\" \
         maxOutputDerivativeOrder=\"0\" canGetAndSetFMUstate=\"true\" canNotUseMemoryManagementFunctions=\"true\"/>",
        info.identifier
    );
    let used: BTreeSet<&str> = info.vars.iter().map(|v| v.unit).filter(|u| !u.is_empty()).collect();
    out.push_str("  <UnitDefinitions>\n");
    for (name, [kg, m, s, k], display) in UNITS.iter().filter(|(n, ..)| used.contains(n)) {
        let _ = write!(out, "    <Unit name=\"{}\">\n      <BaseUnit", escape(name));
        for (exp, attr) in [(kg, "kg"), (m, "m"), (s, "s"), (k, "K")] {
            if *exp != 0 {
                let _ = write!(out, " {attr}=\"{exp}\"");
            }
        }
        out.push_str("/>\n");
        for (d, factor, offset) in display.iter() {
            let _ = writeln!(out, "      <DisplayUnit name=\"{}\" factor=\"{}\" offset=\"{}\"/>", escape(d), number(*factor), number(*offset));
        }
        out.push_str("    </Unit>\n");
    }
    out.push_str("  </UnitDefinitions>\n");
    let mut enums: Vec<_> = info.vars.iter().filter_map(|v| v.enumeration).collect();
    enums.sort_by_key(|e| e.name);
    enums.dedup_by_key(|e| e.name);
    if !enums.is_empty() {
        out.push_str("  <TypeDefinitions>\n");
        for e in enums {
            let _ = writeln!(out, "    <SimpleType name=\"{}\">\n      <Enumeration>", e.name);
            for (name, value, description) in e.items {
                let _ = writeln!(out, "        <Item name=\"{name}\" value=\"{value}\" description=\"{}\"/>", escape(description));
            }
            out.push_str("      </Enumeration>\n    </SimpleType>\n");
        }
        out.push_str("  </TypeDefinitions>\n");
    }
    let _ = writeln!(
        out,
        "  <DefaultExperiment startTime=\"0\" stopTime=\"{}\" stepSize=\"{}\"/>",
        number(info.default_stop_s),
        number(info.default_step_s)
    );
    out.push_str("  <ModelVariables>\n");
    for (vr, v) in info.vars.iter().enumerate() {
        let _ = writeln!(out, "    <!-- index {} -->", vr + 1);
        variable(&mut out, vr, v);
    }
    out.push_str("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n");
    let outputs: Vec<usize> = (0..info.vars.len()).filter(|&i| info.vars.get(i).is_some_and(|v| v.causality == Causality::Output)).collect();
    for i in &outputs {
        let _ = writeln!(out, "      <Unknown index=\"{}\"/>", i + 1);
    }
    out.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        let _ = writeln!(out, "      <Unknown index=\"{}\"/>", i + 1);
    }
    out.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    out
}
