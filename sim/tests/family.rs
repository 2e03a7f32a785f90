//! The family of machines: every sampled parameter stays in its documented range, the
//! draws are deterministic, every axis sweeps one thing, and every family motor keeps the
//! nameplate's no-load speed.
#![allow(
    clippy::float_arithmetic,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::cast_precision_loss,
    clippy::print_stdout,
    reason = "host tests compute expectations in f64, index small recorded vectors and print \
              their figures"
)]

use taut_core::drive::{DUTY_MAX, Direction};
use taut_core::io::Outputs;
use taut_sim::family::{Axis, Span, back_driven_efficiency, ranges as r};
use taut_sim::params::motor_nominal;
use taut_sim::{CurrentSensing, DcLinkSampling, StringKind, Twin, TwinConfig, drive_at, run};

fn assert_in(span: Span, value: f64, what: &str, seed: u64) {
    assert!(span.contains(value), "seed {seed}: {what} = {value} outside {span:?}");
}

/// The motor's Ke (sector-mean, line) for the no-load speed `rpm` at 24 V with the
/// family's derivation at the extreme resistances and inductances.
fn ke_bounds() -> (f64, f64) {
    let mut low = f64::MAX;
    let mut high = 0.0_f64;
    for winding in [r::WINDING_OHM.low, r::WINDING_OHM.high] {
        for mosfet in [r::MOSFET_OHM.low, r::MOSFET_OHM.high] {
            for inductance in [r::INDUCTANCE_H.low, r::INDUCTANCE_H.high] {
                for rpm in [r::NO_LOAD_RPM.low, r::NO_LOAD_RPM.high] {
                    let m = taut_sim::family::family_motor(
                        winding, mosfet, inductance, rpm, 80.0, 0.005,
                    );
                    low = low.min(m.ke_volts_per_rad_s);
                    high = high.max(m.ke_volts_per_rad_s);
                }
            }
        }
    }
    (low, high)
}

#[test]
fn family_parameters_stay_in_their_documented_ranges_over_10000_seeds() {
    let (ke_low, ke_high) = ke_bounds();
    let nominal_inertia = TwinConfig::nominal(StringKind::TennisGut);
    let mut kinds = [0_u32; 5];
    let mut sensing = [0_u32; 3];
    let mut bidirectional = 0_u32;
    let mut ball_screws = 0_u32;
    let mut burst_lengths = [0_u32; 6];
    for seed in 0..10_000_u64 {
        let c = TwinConfig::family(seed);
        assert_eq!(c.check(), Ok(()), "seed {seed}: {c:?}");
        assert_eq!(c, TwinConfig::family(seed), "seed {seed}: not deterministic");
        assert_eq!(c.seed, seed);
        let kind = StringKind::STRINGS.iter().position(|&k| k == c.string.kind);
        kinds[kind.expect("a string is drawn")] += 1;

        let m = c.motor;
        let scale = m.rotor_inertia_kg_m2 / nominal_inertia.motor.rotor_inertia_kg_m2;
        assert_in(r::INERTIA_SCALE, scale, "inertia scale", seed);
        let gear = c.mechanics.gear_inertia_kg_m2 / nominal_inertia.mechanics.gear_inertia_kg_m2;
        assert!((gear - scale).abs() < 1e-9, "seed {seed}: gearbox inertia scales with the rotor");
        let r_low = r::WINDING_OHM.low + r::MOSFET_OHM.low;
        let r_high = r::WINDING_OHM.high + r::MOSFET_OHM.high;
        assert_in(Span::linear(r_low, r_high), m.phase_resistance_ohm, "phase resistance", seed);
        assert_in(r::INDUCTANCE_H, m.phase_inductance_h, "inductance", seed);
        assert_in(Span::linear(ke_low, ke_high), m.ke_volts_per_rad_s, "Ke", seed);
        assert_in(r::EMF_RAMP_DEG, m.emf_ramp_deg, "back-EMF ramp", seed);
        assert_in(r::MOTOR_COULOMB_NM, m.coulomb_torque_nm, "motor Coulomb", seed);
        assert!(m.viscous_nm_per_rad_s > 0.0, "seed {seed}");
        assert_in(r::COGGING_NM, m.cogging_torque_nm, "cogging", seed);
        assert_eq!(m.pole_pairs, 4);

        let b = c.bridge;
        assert_in(r::SUPPLY_VOLTS, b.bus_volts, "supply", seed);
        assert_in(r::SUPPLY_OHM, b.supply_ohm, "supply resistance", seed);
        assert_in(r::BUS_CAPACITANCE_F, b.bus_capacitance_f, "capacitance", seed);
        let clamp = b.clamp_volts.expect("every machine of the family has a clamp");
        assert_in(r::CLAMP_VOLTS, clamp, "clamp", seed);
        assert!(clamp >= r::CLAMP_OVER_SUPPLY * b.bus_volts - 1e-9, "seed {seed}: clamp {clamp}");
        assert_in(r::AUX_LOAD_AMPS, b.aux_load_amps, "auxiliary load", seed);
        assert_in(r::COMPARATOR_AMPS, b.comparator_amps, "comparator", seed);

        let k = c.mechanics;
        // A ball screw is drawn with the family's least drag (exactly its low end).
        if k.drag_torque_nm == r::DRAG_NM.low && k.stiction_ratio == r::STICTION.low {
            // A ball screw (a quarter of the machines): its own spans, realisable.
            assert_in(r::BALL_SCREW_FORWARD, k.efficiency_forward, "η forward (ball)", seed);
            assert_in(r::BALL_SCREW_BACKWARD, k.efficiency_backward, "η back (ball)", seed);
            ball_screws += 1;
        } else {
            assert_in(r::EFFICIENCY_FORWARD, k.efficiency_forward, "η forward", seed);
            let ratio = k.efficiency_backward / k.efficiency_forward;
            assert_in(r::BACK_DRIVE_RATIO, ratio, "η back / forward", seed);
        }
        assert_in(r::OVERTRAVEL_MM, k.overtravel_mm, "end stop past home", seed);
        let (a, b) = k.friction_coefficients();
        assert!(a >= 0.0 && b >= 0.0, "seed {seed}");
        assert_in(r::DRAG_NM, k.drag_torque_nm, "drag", seed);
        assert_in(r::SLIDE_N, k.slide_friction_n, "slide", seed);
        assert_in(r::STICTION, k.stiction_ratio, "stiction", seed);
        assert_in(r::CARRIAGE_KG, k.carriage_mass_kg, "carriage", seed);
        assert_in(r::BACKLASH_MM, k.backlash_mm, "backlash", seed);
        assert_in(r::GRIPPER_KG, k.gripper.mass_kg, "gripper", seed);
        assert_in(r::LOAD_CELL_STIFFNESS, k.gripper.load_cell_stiffness_n_per_m, "cell k", seed);
        assert_in(r::GRIPPER_DAMPING, k.gripper.damping_ratio, "gripper ζ", seed);

        let l = c.load_cell;
        assert_in(r::SENSITIVITY, l.volts_per_kgf, "sensitivity", seed);
        assert_in(r::ZERO_VOLTS, l.zero_volts, "zero", seed);
        assert_in(r::LOW_LOAD_DEFICIT, l.low_load_deficit, "deficit", seed);
        assert_in(r::LOW_LOAD_SCALE_KGF, l.low_load_scale_kgf, "deficit scale", seed);
        assert_in(r::QUADRATIC, l.quadratic_at_50_kgf, "quadratic", seed);
        assert_in(r::BANDWIDTH_HZ, l.bandwidth_hz, "bandwidth", seed);
        assert_in(r::NOISE_VOLTS, l.noise_volts, "noise", seed);
        assert_in(r::HUM_VOLTS, l.hum.volts, "hum", seed);
        let mains = if l.hum.frequency_hz < 55.0 { 50.0 } else { 60.0 };
        assert_in(r::HUM_FREQUENCY_SCALE, l.hum.frequency_hz / mains, "hum frequency", seed);
        assert_in(r::SPIKE_PWM_PROBABILITY, l.spikes.pwm_probability, "spike rate", seed);
        assert_in(
            r::SPIKE_COMMUTATION_PROBABILITY,
            l.spikes.commutation_probability,
            "commutation spikes",
            seed,
        );
        assert_in(r::SPIKE_BASE_VOLTS, l.spikes.base_volts, "spike base", seed);
        assert_in(r::SPIKE_VOLTS_PER_AMP, l.spikes.volts_per_amp, "spike per A", seed);
        assert_in(r::SPIKE_BURST_PROBABILITY, l.spikes.burst_probability, "burst rate", seed);
        assert_in(r::ZERO_DRIFT_VOLTS_PER_S, l.zero_drift_volts_per_s, "zero drift", seed);
        assert_in(r::ZERO_DRIFT_SETTLE_S, l.zero_drift_settle_s, "zero drift settling", seed);
        let burst = l.spikes.burst_samples_max as usize;
        assert!((1..=5).contains(&burst), "seed {seed}: burst {burst}");
        burst_lengths[burst] += 1;

        let s = c.current_sense;
        match s.sensing {
            CurrentSensing::PerPhaseLowSide => {
                sensing[0] += 1;
                assert!(s.bidirectional(), "seed {seed}: per-phase shunts read signed");
            }
            CurrentSensing::DcLink(DcLinkSampling::MidOnTime) => sensing[1] += 1,
            CurrentSensing::DcLink(DcLinkSampling::Filtered { time_constant_s, sample_phase }) => {
                sensing[2] += 1;
                assert_in(r::DC_LINK_RC_S, time_constant_s, "RC", seed);
                assert_in(r::DC_LINK_SAMPLE_PHASE, sample_phase, "sampling phase", seed);
            }
        }
        if s.bidirectional() {
            bidirectional += 1;
            assert!((s.offset_volts - 2.5).abs() < 1e-12 && (s.volts_per_amp - 0.1).abs() < 1e-12);
            assert_in(r::CURRENT_OFFSET_BIDIRECTIONAL, s.offset_amps, "offset", seed);
        } else {
            assert!(s.offset_volts == 0.0 && (s.volts_per_amp - 0.2).abs() < 1e-4);
            assert_in(r::CURRENT_OFFSET_UNIDIRECTIONAL, s.offset_amps, "offset", seed);
        }
        assert_in(r::CURRENT_GAIN_ERROR, s.gain_error, "current gain", seed);
        assert_in(r::CURRENT_NOISE, s.noise_amps, "current noise", seed);
        assert_in(r::BUS_DIVIDER, c.bus_sense.divider_ratio, "divider", seed);
        assert_in(r::BUS_NOISE_VOLTS, c.bus_sense.noise_volts, "bus noise", seed);

        let h = c.hall;
        assert_in(r::HALL_COMMON_DEG, h.offset_deg, "Hall common", seed);
        for offset in h.sensor_offsets_deg {
            assert_in(r::HALL_SENSOR_DEG, offset, "Hall sensor", seed);
            assert_in(r::HALL_EDGE_DEG, h.offset_deg + offset, "Hall edge", seed);
        }
        assert_in(r::HALL_FLIP, h.read_flip_probability, "Hall flips", seed);
        assert_in(r::HALL_BURST, h.burst_probability, "Hall bursts", seed);
        assert_in(r::ENCODER_SCALE_ERROR, c.encoder.scale_error, "encoder", seed);

        let spec = c.string.kind.spec().expect("a string");
        let (low, high) = spec.stiffness_range_kgf_per_cm;
        assert_in(Span::linear(low, high), c.string.stiffness_kgf_per_cm, "stiffness", seed);
        assert_in(r::SLACK_MM, c.string.slack_mm, "slack", seed);
        assert_in(r::TOE_MM, c.string.toe_mm, "toe", seed);
        assert_in(r::HYSTERESIS_STRAIN_MM, c.string.hysteresis_strain_mm, "δ", seed);
        assert_in(r::STRING_HYSTERESIS, c.string.hysteresis_fraction, "hysteresis", seed);
        for (arm, nominal) in c.string.relaxation.iter().zip(spec.relaxation) {
            let f = arm.fraction / nominal.fraction;
            let t = arm.time_constant_s / nominal.time_constant_s;
            assert_in(r::RELAXATION_FRACTION_SCALE, f, "relaxation fraction", seed);
            assert_in(r::RELAXATION_TIME_SCALE, t, "relaxation time", seed);
        }
    }
    println!(
        "string kinds {kinds:?}, sensing (per-phase, mid-on, RC) {sensing:?}, bidirectional {bidirectional}"
    );
    // Every kind and board is drawn, about evenly.
    assert!(kinds.iter().all(|&n| n > 1_700), "{kinds:?}");
    assert!(sensing.iter().all(|&n| n > 3_000), "{sensing:?}");
    assert!(bidirectional > 6_000 && bidirectional < 7_300, "{bidirectional}");
    // About a quarter ball screws; every burst length 1 ..= 5 drawn.
    assert!((2_200..2_800).contains(&ball_screws), "{ball_screws} ball screws");
    assert!(burst_lengths[1..].iter().all(|&n| n > 1_000), "{burst_lengths:?}");
}

#[test]
fn family_draws_fill_their_ranges() {
    // The low-friction end is really drawn: some machines have a ball-screw-like drivetrain.
    let configs: Vec<TwinConfig> = (0..2_000).map(TwinConfig::family).collect();
    let max = |f: &dyn Fn(&TwinConfig) -> f64| configs.iter().map(f).fold(f64::MIN, f64::max);
    let min = |f: &dyn Fn(&TwinConfig) -> f64| configs.iter().map(f).fold(f64::MAX, f64::min);
    assert!(max(&|c| c.mechanics.efficiency_forward) > 0.85);
    assert!(min(&|c| c.mechanics.efficiency_forward) < 0.51);
    assert!(min(&|c| c.mechanics.stiction_ratio) < 1.03);
    assert!(max(&|c| c.motor.rotor_inertia_kg_m2) > 2.9e-5);
    assert!(min(&|c| c.motor.rotor_inertia_kg_m2) < 0.76e-5);
    assert!(max(&|c| c.bridge.bus_volts) > 29.9 && min(&|c| c.bridge.bus_volts) < 20.1);
    assert!(max(&|c| c.mechanics.backlash_mm) > 0.19);
    assert!(max(&|c| c.load_cell.spikes.base_volts) > 0.39);
    // The warm-up drifts both ways; the string's hysteresis spans none to 3 %.
    assert!(max(&|c| c.load_cell.zero_drift_volts_per_s) > 0.099e-3);
    assert!(min(&|c| c.load_cell.zero_drift_volts_per_s) < -0.099e-3);
    assert!(max(&|c| c.string.hysteresis_fraction) > 0.0299);
    assert!(min(&|c| c.string.hysteresis_fraction) < 0.0001);
}

#[test]
fn every_axis_moves_its_own_parameters_from_the_centre() {
    for kind in StringKind::STRINGS {
        let centre = TwinConfig::family_centre(kind);
        assert_eq!(centre.check(), Ok(()));
        for axis in Axis::ALL {
            let low = TwinConfig::on_axis(axis, 0.0, kind);
            let high = TwinConfig::on_axis(axis, 1.0, kind);
            for p in [0.0, 0.25, 0.5, 0.75, 1.0] {
                let c = TwinConfig::on_axis(axis, p, kind);
                assert_eq!(c.check(), Ok(()), "{axis} at {p}: {c:?}");
            }
            assert_ne!(low, high, "{axis} does not move");
            // Nothing outside the axis's own part moves.
            let part = |c: &TwinConfig| -> [bool; 8] {
                [
                    c.motor != centre.motor,
                    c.bridge != centre.bridge,
                    c.mechanics != centre.mechanics,
                    c.string != centre.string,
                    c.load_cell != centre.load_cell,
                    c.current_sense != centre.current_sense,
                    c.hall != centre.hall,
                    c.bus_sense != centre.bus_sense || c.encoder != centre.encoder,
                ]
            };
            let changed: Vec<bool> =
                part(&low).iter().zip(part(&high)).map(|(a, b)| *a || b).collect();
            // Inertia moves the rotor (motor) and the gearbox (mechanics); every other axis
            // one part.
            let parts = if axis == Axis::Inertia { 2 } else { 1 };
            assert_eq!(changed.iter().filter(|&&c| c).count(), parts, "{axis}: {changed:?}");
            println!("{}", axis.span_for(kind));
        }
    }
    // The friction axis's low end is the ball-screw-like drivetrain.
    let ball = TwinConfig::on_axis(Axis::Friction, 0.0, StringKind::TennisGut).mechanics;
    assert!(ball.efficiency_forward > 0.85 && ball.stiction_ratio < 1.03);
    let ratio = ball.efficiency_backward / ball.efficiency_forward;
    assert!((ratio - back_driven_efficiency(0.86, 0.0) / 0.86).abs() < 1e-12 && ratio > 0.97);
    // The current-sensing axis steps through the five boards.
    let boards: Vec<String> = (0..5)
        .map(|k| {
            TwinConfig::on_axis(Axis::CurrentSensing, f64::from(k) / 4.0, StringKind::TennisGut)
                .current_sense
                .name()
        })
        .collect();
    assert_eq!(
        boards,
        [
            "dc-link-mid-on/unidirectional",
            "dc-link-mid-on/bidirectional",
            "dc-link-rc/unidirectional",
            "dc-link-rc/bidirectional",
            "per-phase/bidirectional"
        ]
    );
}

/// The twin's no-load speed at 24 V on the motor bench, extrapolated from 95 % duty to
/// 100 % as `no_load_speed_extrapolates_to_the_papers_3700_rpm` does, rpm.
fn no_load_rpm_at_24_volts(mut config: TwinConfig) -> f64 {
    config.mechanics.decoupled = true;
    config.string = taut_sim::params::StringParams::nominal(StringKind::NoString);
    config.bridge.bus_volts = 24.0;
    config.bridge.clamp_volts = None;
    // taut-core reads the current as taut's own board gives it (a bidirectional board's
    // mid-rail zero would read as 12.5 A and trip the drive).
    config.current_sense = taut_sim::CurrentSenseParams::nominal();
    let m = config.motor;
    let mut twin = Twin::new(&config);
    let mut tick = 0_u32;
    let trace = run(&mut twin, 2_000, |_| {
        tick += 1;
        let ramp = (f64::from(tick) / 400.0).min(1.0);
        Outputs { drive: drive_at(Direction::Pull, ramp), ..Outputs::default() }
    });
    assert_eq!(twin.truth().drive_fault, None);
    let tail = &trace.rows[1_600..];
    let mean = |f: &dyn Fn(&taut_sim::TraceRow) -> f64| {
        tail.iter().map(f).sum::<f64>() / tail.len() as f64
    };
    let rpm = mean(&|row| row.truth.motor_rpm);
    let bus = mean(&|row| row.truth.bus_volts);
    let duty = f64::from(DUTY_MAX.raw()) / 65_536.0;
    let dead = config.bridge.dead_time_s * f64::from(taut_sim::twin::PWM_FREQUENCY_HZ);
    let applied = (duty - dead) * bus - 2.0 * dead * config.bridge.diode_drop_v;
    let r = 2.0 * m.phase_resistance_ohm;
    let ke = m.ke_volts_per_rad_s;
    let omega_at = |volts: f64| {
        (volts - r * m.coulomb_torque_nm / ke) / (ke + r * m.viscous_nm_per_rad_s / ke)
    };
    rpm * omega_at(motor_nominal::BUS_VOLTS) / omega_at(applied)
}

#[test]
fn family_motors_keep_the_nameplate_no_load_speed_within_5_percent() {
    let mut worst: f64 = 0.0;
    let mut check = |what: String, config: TwinConfig| {
        let rpm = no_load_rpm_at_24_volts(config);
        let error = rpm / 3_700.0 - 1.0;
        println!("{what}: {rpm:.0} rpm ({:+.2} %)", 100.0 * error);
        worst = worst.max(error.abs());
    };
    check("centre".into(), TwinConfig::family_centre(StringKind::NoString));
    for axis in [
        Axis::MotorSpeedConstant,
        Axis::MotorResistance,
        Axis::MotorInductance,
        Axis::BackEmfShape,
        Axis::Inertia,
    ] {
        for p in [0.0, 1.0] {
            check(format!("{axis} at {p}"), TwinConfig::on_axis(axis, p, StringKind::NoString));
        }
    }
    for seed in 0..12 {
        check(format!("family {seed}"), TwinConfig::family(seed));
    }
    assert!(worst < 0.05, "worst no-load speed error {:.2} %", 100.0 * worst);
}
