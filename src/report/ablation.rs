//! `taut report ablation`: taut's controller with each improvement switched off in turn, on
//! the accuracy report's scenarios (same machines, same commissioning calibration).

use taut_core::tension::ControllerConfig;
use taut_core::tension::motor::DutyMap;

use super::Machines;
use super::accuracy::{Entry, markdown, run_all, to_json};
use crate::cli::AblationArgs;
use crate::output::{Outputs, Status, json_bytes, threads};

/// taut with each of its improvements switched off in turn: the law's four (boundary
/// layer, bounded adaptation, anti-windup, rate filter), the back-EMF feed-forward of the
/// voltage-drive plant, the profile's and estimator's (braking approach, plant adaptation to
/// the identified stiffness, observer, spike clip, slip damping in the hold), and the
/// machine's 4-point calibration.
#[must_use]
pub fn lineup() -> Vec<Entry> {
    use taut_core::tension::controller::{LawConfig, TAUT_GAINS};
    use taut_core::tension::law::{NominalPlant, RsmcGains};
    use taut_core::tension::profile::ProfileConfig;
    use taut_core::units::Q16;
    let taut = ControllerConfig::TAUT;
    let law = |f: &dyn Fn(&mut RsmcGains)| {
        let mut gains = TAUT_GAINS;
        f(&mut gains);
        ControllerConfig { law: LawConfig::Rsmc(gains), ..taut }
    };
    let profile = |f: &dyn Fn(&mut ProfileConfig)| {
        let mut p = ProfileConfig::TAUT;
        f(&mut p);
        ControllerConfig { profile: p, ..taut }
    };
    // Without the back-EMF in the nominal plant (Ā = 2 s⁻¹, screw friction only) the law
    // neither feeds the reference's back-EMF forward nor expects the drive's damping.
    let no_back_emf = |gains: &mut RsmcGains| {
        gains.plant = NominalPlant { a_bar: Q16::const_from_int(2), ..gains.plant };
    };
    let entry = |name, config| Entry { name, config, calibrated: true };
    vec![
        entry("taut", taut),
        entry("sgn instead of boundary layer", law(&|g| g.improvements.boundary_layer = None)),
        entry("unbounded adaptation", law(&|g| g.improvements.bounded_adaptation = None)),
        entry("no anti-windup", law(&|g| g.improvements.anti_windup = None)),
        entry("raw error rate (no rate filter)", law(&|g| g.improvements.rate_filter = None)),
        entry("no back-EMF in the plant", law(&no_back_emf)),
        entry(
            "current-command duty map",
            ControllerConfig {
                duty_map: DutyMap::BackEmf {
                    current_limit: taut_core::tension::controller::CURRENT_LIMIT,
                },
                ..law(&no_back_emf)
            },
        ),
        entry("step set point (no braking approach)", profile(&|p| p.shaped = false)),
        entry("no plant adaptation", profile(&|p| p.adapt_plant = false)),
        entry("no observer", profile(&|p| p.observer_gain = None)),
        entry("no spike clip", profile(&|p| p.spike_clip = false)),
        entry("no slip damping (friction-aware hold)", profile(&|p| p.slip_damping = None)),
        Entry { name: "uncalibrated sensor", config: taut, calibrated: false },
    ]
}

/// `taut report ablation`.
///
/// # Errors
/// The JSON file cannot be written.
pub fn main(args: &AblationArgs) -> Status {
    let outputs = Outputs::new().file("--json", args.json.as_deref()).check()?;
    let lineup = lineup();
    let machines = Machines { sensing: args.sensing, gauge_sigma: None };
    let results = run_all(args.seed, args.scenarios, machines, &lineup, threads(args.threads));
    let files: Vec<_> = args
        .json
        .iter()
        .map(|path| (path.clone(), json_bytes(&to_json(args.seed, machines, &results, &lineup))))
        .collect();
    outputs.write(&files)?;
    println!("{}", markdown(&results, &lineup));
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(true)
}
