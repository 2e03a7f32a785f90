//! Physics sanity of the twin: each test drives the twin through taut-core's drive and
//! checks one physical behaviour against the number it was derived from, with a margin.
#![allow(
    clippy::float_arithmetic,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::expect_used,
    reason = "host tests compute expectations in f64, index small recorded vectors, and a \
              helper's failed expectation is a test failure"
)]

use taut_core::drive::{DUTY_MAX, Direction, DriveFault, HallCode, Phase, Sector, SectorStep};
use taut_core::io::{Key, Keys, Outputs};
use taut_core::sense::current;
use taut_sim::motor::sector_shape_factor;
use taut_sim::params::NEWTONS_PER_KGF;
use taut_sim::{
    Fault, LimitSwitch, LoadCellFault, StringKind, StringState, Trace, Twin, TwinConfig, drive_at,
    run, run_until,
};

/// Drive in `direction` at `duty`, ramping up over the first `ramp_ms` of the run (a step
/// to high duty into a standing motor trips the 12 A limit, as it would on the machine).
fn ramped(
    direction: Direction,
    duty: f64,
    ramp_ms: u32,
) -> impl FnMut(&taut_core::io::Inputs) -> Outputs {
    let mut tick = 0_u32;
    move |_| {
        tick += 1;
        let ramp = if ramp_ms == 0 { 1.0 } else { (f64::from(tick) / f64::from(ramp_ms)).min(1.0) };
        Outputs { drive: drive_at(direction, duty * ramp), ..Outputs::default() }
    }
}

fn coast() -> impl FnMut(&taut_core::io::Inputs) -> Outputs {
    |_| Outputs::default()
}

/// Sensor noise and spikes off, for tests that read sensors against the truth.
fn quiet(kind: StringKind) -> TwinConfig {
    let mut config = TwinConfig::nominal(kind);
    config.load_cell.noise_volts = 0.0;
    config.load_cell.spikes.pwm_probability = 0.0;
    config.load_cell.spikes.commutation_probability = 0.0;
    config.current_sense.noise_amps = 0.0;
    config
}

/// The mean line voltage the complementary bridge applies to the driven pair at `duty` on a
/// bus of `bus` volts while the current flows forward: the high side for `D·T − t_d`, the
/// low body diode for the two dead times, the low side for the rest.
fn line_volts(config: &TwinConfig, duty: f64, bus: f64) -> f64 {
    let b = config.bridge;
    let dead = b.dead_time_s * f64::from(taut_sim::twin::PWM_FREQUENCY_HZ);
    (duty - dead) * bus - 2.0 * dead * b.diode_drop_v
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0.0), |(s, n), v| (s + v, n + 1.0));
    sum / n
}

/// The Hall codes in the order the rotor went through them (consecutive repeats removed).
fn hall_sequence(trace: &Trace) -> Vec<HallCode> {
    let mut codes: Vec<HallCode> = Vec::new();
    for row in &trace.rows {
        if codes.last() != Some(&row.truth.hall) {
            codes.push(row.truth.hall);
        }
    }
    codes
}

fn sector(code: HallCode) -> Sector {
    code.sector().expect("a healthy rotor reads a valid code")
}

#[test]
fn no_load_speed_extrapolates_to_the_papers_3700_rpm() {
    let config = TwinConfig::motor_bench();
    let m = config.motor;
    let b = config.bridge;
    let mut twin = Twin::new(&config);
    let duty = f64::from(DUTY_MAX.raw()) / 65_536.0;
    let trace = run(&mut twin, 1_500, ramped(Direction::Pull, 1.0, 300));
    assert_eq!(twin.truth().drive_fault, None);
    let rpm = mean(trace.rows[1_200..].iter().map(|r| r.truth.motor_rpm));

    // Steady state: Ke·ω + 2R·I₀(ω) = the complementary bridge's line voltage (duty·V less
    // the dead-time loss), with I₀(ω) = (T_c + c·ω)/Ke; V is the bus as the twin loads it.
    let r = 2.0 * m.phase_resistance_ohm;
    let ke = m.ke_volts_per_rad_s;
    let omega_at = |volts: f64| {
        (volts - r * m.coulomb_torque_nm / ke) / (ke + r * m.viscous_nm_per_rad_s / ke)
    };
    let bus = mean(trace.rows[1_200..].iter().map(|r| r.truth.bus_volts));
    assert!(bus < b.bus_volts && bus > b.bus_volts - 0.1, "bus {bus}");
    let line_volts = line_volts(&config, duty, bus);
    let expected_rpm = omega_at(line_volts) * 60.0 / std::f64::consts::TAU;
    let at_full_bus = rpm * omega_at(b.bus_volts) / omega_at(line_volts);
    println!(
        "no-load at duty {duty:.4}: {rpm:.0} rpm (model {expected_rpm:.0}); at 100 % \
         equivalent {at_full_bus:.0} rpm (paper 3700)"
    );
    // The steady-state equation omits the commutation overlap: at every sector change the
    // current must move from one phase inductance to another, which costs a speed-
    // proportional voltage (≈ 0.5 V at full speed, like a rectifier's overlap drop), so the
    // twin runs ≈ 2.5 % below it at full speed — well inside a datasheet's ±10 %.
    assert!(rpm < expected_rpm && rpm > 0.96 * expected_rpm, "{rpm} vs {expected_rpm}");
    assert!((at_full_bus / 3700.0 - 1.0).abs() < 0.04, "{at_full_bus}");
    // And the no-load current is the I₀ that reconciles Ke with the rated torque.
    let amps = mean(trace.rows[1_200..].iter().map(|r| r.truth.current_a));
    let (_, i0) = taut_sim::params::motor_nominal::ke_and_no_load_current();
    assert!((amps - i0).abs() < 0.15, "no-load current {amps} vs I₀ {i0}");
}

#[test]
fn stall_current_is_the_averaged_voltage_over_the_winding_resistance() {
    let config = quiet(StringKind::NoString);
    let mut twin = Twin::new(&config);
    twin.inject(Fault::CarriageJam);
    let duty = 0.2;
    let trace = run(&mut twin, 60, ramped(Direction::Pull, duty, 0));
    let last = trace.last().expect("ran").truth;
    let applied = f64::from(drive_at(Direction::Pull, duty).duty().raw()) / 65_536.0;
    let r = 2.0 * config.motor.phase_resistance_ohm;
    let expected = line_volts(&config, applied, last.bus_volts) / r;
    println!("stall at duty {applied:.3}: {:.3} A (model {expected:.3} A)", last.current_a);
    assert!((last.current_a / expected - 1.0).abs() < 0.03, "{} vs {expected}", last.current_a);
    // The current sense reports it through taut-core's gain.
    let sensed = current::amps(trace.last().expect("ran").inputs.motor_current).0.to_num::<f64>();
    assert!((sensed - expected).abs() < 0.1, "{sensed}");
    // Torque per ampere is Kt within the six-step ripple band.
    let kt = config.motor.ke_volts_per_rad_s;
    let ripple_peak = 1.0 / sector_shape_factor(config.motor.emf_ramp_deg);
    let per_amp = last.torque_nm / last.current_a;
    assert!(per_amp > 0.85 * kt && per_amp < ripple_peak * kt * 1.001, "{per_amp} vs Kt {kt}");
}

#[test]
fn pulling_produces_the_papers_forward_hall_sequence_and_steps() {
    let mut twin = Twin::new(&quiet(StringKind::TennisSynthetic));
    let trace = run(&mut twin, 600, ramped(Direction::Pull, 0.2, 0));
    let codes = hall_sequence(&trace);
    assert!(codes.len() > 12, "the rotor must turn: {} codes", codes.len());
    for pair in codes.windows(2) {
        assert_eq!(
            SectorStep::between(sector(pair[0]), sector(pair[1])),
            SectorStep::Forward,
            "{pair:?}"
        );
    }
    // The paper's figure 16 order, 101 → 100 → 110 → 010 → 011 → 001, appears verbatim.
    let paper: Vec<HallCode> =
        [0b101, 0b100, 0b110, 0b010, 0b011, 0b001].into_iter().map(HallCode::from_raw).collect();
    let start = codes.iter().position(|&c| c == paper[0]).expect("101 seen");
    assert_eq!(&codes[start..start + 6], paper.as_slice());
    let status = twin.drive().status();
    assert_eq!(status.rotation, Some(Direction::Pull));
    assert!(status.steps > 12, "{}", status.steps);
    assert!(twin.truth().carriage_mm > 0.5);
    // One Hall step is 1/24 motor turn = 25.4 mm / 480 of carriage travel.
    let travel = twin.truth().carriage_mm - twin.config().mechanics.start_mm;
    let per_step = travel / f64::from(status.steps);
    assert!((per_step / (25.4 / 480.0) - 1.0).abs() < 0.1, "{per_step} mm per step");
}

#[test]
fn release_turns_the_motor_backward_toward_home() {
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    run(&mut twin, 800, ramped(Direction::Pull, 0.3, 0));
    run(&mut twin, 200, coast());
    let out_mm = twin.truth().carriage_mm;
    let steps_out = twin.drive().status().steps;
    let trace = run(&mut twin, 500, ramped(Direction::Release, 0.2, 0));
    let codes = hall_sequence(&trace);
    assert!(codes.len() > 6);
    for pair in codes.windows(2) {
        assert_eq!(SectorStep::between(sector(pair[0]), sector(pair[1])), SectorStep::Backward);
    }
    assert_eq!(twin.drive().status().rotation, Some(Direction::Release));
    assert!(twin.drive().status().steps < steps_out);
    assert!(twin.truth().carriage_mm < out_mm - 1.0);
    assert!(trace.rows.iter().all(|r| r.truth.torque_nm <= 0.01), "reverse torque only");
}

#[test]
fn tension_rises_only_after_the_slack_is_taken_up() {
    let config = quiet(StringKind::TennisPolyester);
    let taut_mm = config.mechanics.start_mm + config.string.slack_mm;
    let mut twin = Twin::new(&config);
    let trace = run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.5, 50), |r| {
        r.truth.tension_kgf > 20.0
    });
    let mut saw_slack = false;
    for row in &trace.rows {
        let t = row.truth;
        if t.carriage_mm < taut_mm {
            assert_eq!(t.tension_kgf, 0.0, "slack at {} mm", t.carriage_mm);
            assert_eq!(t.string, StringState::Slack);
            saw_slack = true;
        }
        if t.carriage_mm > taut_mm + config.string.toe_mm + 2.0 {
            assert!(t.tension_kgf > 1.0, "taut at {} mm: {}", t.carriage_mm, t.tension_kgf);
        }
    }
    assert!(saw_slack && twin.truth().tension_kgf > 20.0);
    // Above the toe the pull sees roughly the instantaneous stiffness (a little less: the
    // fast relaxation arm gives way during the pull).
    let at = |kgf: f64| trace.rows.iter().find(|r| r.truth.tension_kgf >= kgf).expect("reached");
    let (a, b) = (at(8.0).truth, at(18.0).truth);
    let k = (b.tension_kgf - a.tension_kgf) / ((b.carriage_mm - a.carriage_mm) / 10.0);
    let k0 = config.string.stiffness_kgf_per_cm;
    println!("stiffness during the pull {k:.2} kgf/cm (K₀ {k0:.2})");
    assert!(k > 0.85 * k0 && k <= 1.01 * k0, "{k} vs {k0}");
}

#[test]
fn a_string_held_at_constant_length_relaxes() {
    let config = quiet(StringKind::TennisPolyester);
    let mut twin = Twin::new(&config);
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.5, 50), |r| r.truth.tension_kgf > 20.0);
    twin.inject(Fault::CarriageJam);
    let trace = run(&mut twin, 10_000, coast());
    let first = trace.rows[0].truth.tension_kgf;
    let last = trace.last().expect("ran").truth.tension_kgf;
    let share: f64 = config.string.relaxation.iter().map(|a| a.fraction).sum();
    println!("relaxation at fixed length: {first:.2} → {last:.2} kgf in 10 s");
    assert!(last < 0.985 * first, "must relax: {first} → {last}");
    assert!(last > (1.0 - share) * first, "not below the equilibrium spring");
    // Monotone: a held string never gains tension.
    assert!(trace.rows.windows(2).all(|w| w[1].truth.tension_kgf <= w[0].truth.tension_kgf + 1e-9));
    // So a head that holds tension must keep creeping forward: undo the jam and hold the
    // true tension with a slow integral law; the carriage advances.
    twin.clear_injected();
    let target = first;
    let mut integral: f64 = 0.15;
    let mut truth = twin.truth();
    let mut hold = |twin: &mut Twin, ms: u32| {
        let mut worst: f64 = 0.0;
        for _ in 0..ms {
            let error = target - truth.tension_kgf;
            integral = (integral + 5e-4 * error).clamp(0.0, 0.5);
            let duty = (integral + 0.05 * error).clamp(0.0, 0.6);
            twin.apply(&Outputs { drive: drive_at(Direction::Pull, duty), ..Outputs::default() });
            twin.advance_tick();
            truth = twin.truth();
            worst = worst.max(error.abs());
        }
        worst
    };
    hold(&mut twin, 3_000);
    let start_mm = twin.truth().carriage_mm;
    let worst = hold(&mut twin, 7_000);
    let end_mm = twin.truth().carriage_mm;
    println!(
        "creep under constant pull: carriage {start_mm:.2} → {end_mm:.2} mm, tension within {worst:.2} kgf"
    );
    assert!(worst < 1.0, "the hold held: {worst}");
    // 13 s after the pull the slow arm (τ = 60 s) still relaxes ≈ 0.02 kgf/s: ≈ 0.15 mm
    // of creep in 7 s on a 12.5 kgf/cm string.
    assert!(end_mm > start_mm + 0.08, "{start_mm} → {end_mm}");
}

#[test]
fn load_cell_reads_about_920_mv_at_10_kgf() {
    let config = quiet(StringKind::TennisSynthetic);
    let mut twin = Twin::new(&config);
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.3, 0), |r| r.truth.tension_kgf >= 10.0);
    twin.inject(Fault::CarriageJam);
    run(&mut twin, 5, coast());
    let truth = twin.truth();
    let code = twin.inputs().load_cell;
    let volts = taut_sim::sensors::FIVE_VOLTS.volts(code).0.to_num::<f64>();
    // Scale to exactly 10 kgf with the chain's local slope (the string relaxes a little).
    let per_kgf = config.load_cell.volts_per_kgf;
    let at_ten = volts + (10.0 - truth.tension_kgf) * per_kgf;
    println!(
        "load cell at {:.3} kgf: code {} = {volts:.4} V → {at_ten:.4} V at 10 kgf",
        truth.tension_kgf,
        code.get()
    );
    assert!((at_ten - 0.92).abs() < 0.04, "{at_ten} V");
    // One code is 1.22 mV: the reading is the analogue output within a code.
    assert!((volts - truth.load_cell_volts).abs() < 0.0013);
}

#[test]
fn switching_spikes_come_with_the_pwm_and_commutation() {
    let mut config = TwinConfig::nominal(StringKind::NoString);
    config.load_cell.spikes.pwm_probability = 0.1;
    let spikes = |trace: &Trace| {
        trace
            .rows
            .iter()
            .filter(|r| {
                let code = i32::from(r.inputs.load_cell.get());
                let clean = i32::from(taut_sim::sensors::adc(r.truth.load_cell_volts).get());
                (code - clean).abs() > 15
            })
            .count()
    };
    let mut twin = Twin::new(&config);
    let idle = run(&mut twin, 2_000, coast());
    let driving = run(&mut twin, 2_000, ramped(Direction::Pull, 0.3, 0));
    let (idle, driving) = (spikes(&idle), spikes(&driving));
    println!("samples with a spike: {idle} of 2000 idle, {driving} of 2000 driving");
    assert_eq!(idle, 0);
    assert!(driving > 100, "{driving}");
}

#[test]
fn limit_switches_trip_at_the_ends_of_travel_and_stop_the_drive() {
    let config = quiet(StringKind::NoString);
    let m = config.mechanics;
    let mut twin = Twin::new(&config);
    assert!(twin.inputs().limits.home, "powers up resting on the home switch");
    let out =
        run_until(&mut twin, 20_000, ramped(Direction::Pull, 0.9, 100), |r| r.inputs.limits.end);
    let end_row = out.last().expect("ran");
    assert!(end_row.inputs.limits.end);
    assert!(end_row.truth.carriage_mm >= m.end_switch_mm);
    // A tick's inputs are sampled where the previous tick left the carriage.
    for pair in out.rows.windows(2) {
        let (before, now) = (pair[0].truth, pair[1].inputs);
        assert_eq!(now.limits.end, before.carriage_mm >= m.end_switch_mm);
        assert_eq!(now.limits.home, before.carriage_mm <= m.home_switch_mm);
    }
    assert!(out.rows.iter().any(|r| !r.inputs.limits.home && !r.inputs.limits.end));
    // The drive refuses to push into the active end switch; the carriage coasts to rest
    // before the hard stop.
    let after = run(&mut twin, 2_000, ramped(Direction::Pull, 0.9, 0));
    assert!(after.rows.iter().skip(2).all(|r| !r.inputs.limits.end || r.truth.duty == 0.0));
    let rest = twin.truth().carriage_mm;
    println!("end switch at {} mm, carriage came to rest at {rest:.1} mm", m.end_switch_mm);
    assert!(rest >= m.end_switch_mm && rest < m.end_switch_mm + m.overtravel_mm);
    // Back home.
    let back = run_until(&mut twin, 20_000, ramped(Direction::Release, 0.9, 100), |r| {
        r.inputs.limits.home
    });
    assert!(back.last().expect("ran").truth.carriage_mm <= m.home_switch_mm);
    assert_eq!(twin.truth().drive_fault, None);
}

#[test]
fn same_seed_same_trace_different_seed_different_trace() {
    let go = |seed| {
        let mut twin = Twin::new(&TwinConfig::sample(seed));
        run(&mut twin, 1_500, ramped(Direction::Pull, 0.6, 100))
    };
    let (a, b, c) = (go(42), go(42), go(43));
    assert_eq!(a, b, "bit-identical replay");
    assert_ne!(a, c);
}

#[test]
fn string_break_drops_the_tension_and_stops_the_encoder() {
    let mut config = quiet(StringKind::TennisSynthetic);
    config.string.break_at_kgf = Some(15.0);
    let mut twin = Twin::new(&config);
    let trace = run(&mut twin, 3_000, ramped(Direction::Pull, 0.4, 0));
    let broke =
        trace.rows.iter().position(|r| r.truth.string == StringState::Broken).expect("broke");
    assert!(trace.rows[broke - 1].truth.tension_kgf > 14.0);
    assert!(trace.rows[broke..].iter().all(|r| r.truth.tension_kgf == 0.0));
    let counter = trace.rows[broke + 5].inputs.string_counter;
    assert_eq!(trace.last().expect("ran").inputs.string_counter, counter, "wheel stops");
    // The load cell falls back to its zero.
    let code = trace.last().expect("ran").inputs.load_cell;
    let code = taut_sim::sensors::FIVE_VOLTS.volts(code).0.to_num::<f64>();
    assert!((code - config.load_cell.zero_volts).abs() < 0.005);

    // And on request.
    let mut twin = Twin::new(&quiet(StringKind::TennisGut));
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.4, 0), |r| r.truth.tension_kgf > 10.0);
    twin.break_string();
    run(&mut twin, 2, coast());
    assert_eq!(twin.truth().tension_kgf, 0.0);
    assert_eq!(twin.truth().string, StringState::Broken);
}

#[test]
fn no_string_never_builds_tension() {
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    let trace = run(&mut twin, 3_000, ramped(Direction::Pull, 0.6, 100));
    assert!(trace.rows.iter().all(|r| r.truth.tension_kgf == 0.0));
    assert!(trace.rows.iter().all(|r| r.inputs.string_counter == 0));
    assert!(twin.truth().carriage_mm > 50.0);
}

#[test]
fn encoder_counts_eight_per_millimetre_of_string() {
    let mut twin = Twin::new(&quiet(StringKind::TennisSynthetic));
    run(&mut twin, 1_000, ramped(Direction::Pull, 0.3, 0));
    let travel = twin.truth().string_travel_mm;
    let counts = f64::from(twin.inputs().string_counter);
    assert!(travel > 10.0);
    assert!((counts - 8.0 * travel).abs() <= 1.0, "{counts} vs {travel} mm");
}

#[test]
fn overcurrent_protection_stops_a_stall_at_high_duty() {
    // taut's drive limits the current by its duty window: a stall commanded at full duty
    // stays under the limit (8 A; the machine's stall rule, E-09, then stops it) …
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    twin.inject(Fault::CarriageJam);
    let trace = run(&mut twin, 40, ramped(Direction::Pull, 0.95, 0));
    let peak = trace.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    println!("stall, current-limited drive: {:?}, peak {peak:.2} A", twin.truth().drive_fault);
    assert_eq!(twin.truth().drive_fault, None);
    assert!(peak < 0.8 * 12.0, "{peak}");

    // … in plain voltage mode the software limit (12 A, sampled every PWM period) catches it …
    let mut twin = Twin::new(&quiet(StringKind::NoString)).with_voltage_mode_drive();
    twin.inject(Fault::CarriageJam);
    // (The drive first waits REVERSAL_QUIET = 20 ms for a quiet rotor after power-up.)
    let trace = run(&mut twin, 40, ramped(Direction::Pull, 0.95, 0));
    let peak = trace.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    println!("stall, software limit: {:?}, peak {peak:.2} A", twin.truth().drive_fault);
    assert_eq!(twin.truth().drive_fault, Some(DriveFault::Overcurrent));
    assert!(peak < 13.0, "{peak}");

    // … and with the current sense lost, the hardware comparator trips at its level.
    let mut twin = Twin::new(&quiet(StringKind::NoString)).with_voltage_mode_drive();
    twin.inject(Fault::CarriageJam);
    twin.inject(Fault::CurrentSenseOpen);
    let trace = run(&mut twin, 40, ramped(Direction::Pull, 0.95, 0));
    let peak = trace.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    let level = twin.config().bridge.comparator_amps;
    println!("stall, sense lost: {:?}, peak {peak:.2} A", twin.truth().drive_fault);
    assert!(trace.rows.iter().any(|r| r.truth.comparator_tripped));
    assert_eq!(twin.truth().drive_fault, Some(DriveFault::OvercurrentTrip));
    assert!(peak >= level - 0.01 && peak < level + 0.5, "{peak}");
    assert!(twin.truth().current_a < 0.01, "bridge off, current decayed");
}

#[test]
fn hall_faults_reach_the_drive_through_its_filters() {
    // A one-period glitch is filtered by the two-read confirmation.
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    run(&mut twin, 100, ramped(Direction::Pull, 0.2, 0));
    let far = sector(twin.truth().hall).advanced(3).hall_code();
    twin.inject(Fault::HallGlitch { code: far, periods: 1 });
    run(&mut twin, 100, ramped(Direction::Pull, 0.2, 0));
    assert_eq!(twin.truth().drive_fault, None);
    // A longer one is accepted and the jump latches a fault.
    let far = sector(twin.truth().hall).advanced(3).hall_code();
    twin.inject(Fault::HallGlitch { code: far, periods: 4 });
    run(&mut twin, 10, ramped(Direction::Pull, 0.2, 0));
    assert_eq!(twin.truth().drive_fault, Some(DriveFault::SectorSkipped));

    // A stuck line produces an impossible code as soon as the rotor turns.
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    twin.inject(Fault::HallLineStuck { phase: Phase::A, level: true });
    run(&mut twin, 500, ramped(Direction::Pull, 0.2, 0));
    assert!(matches!(
        twin.truth().drive_fault,
        Some(DriveFault::HallInvalid | DriveFault::SectorSkipped)
    ));

    // Read glitches at the rate the Monte-Carlo draws are voted out.
    let mut config = quiet(StringKind::NoString);
    config.hall.read_flip_probability = 0.01;
    let mut twin = Twin::new(&config);
    run(&mut twin, 2_000, ramped(Direction::Pull, 0.5, 100));
    assert_eq!(twin.truth().drive_fault, None);
}

#[test]
fn wiring_faults_read_as_wired() {
    let mut twin = Twin::new(&quiet(StringKind::TennisSynthetic));
    twin.inject(Fault::LimitSwitchStuck { switch: LimitSwitch::End, closed: true });
    let trace = run(&mut twin, 300, ramped(Direction::Pull, 0.3, 0));
    assert!(trace.rows.iter().all(|r| r.inputs.limits.end && !r.truth.limits.end));
    assert!(twin.truth().carriage_mm < 0.0, "the drive will not pull into a closed end switch");

    twin.clear_injected();
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.3, 0), |r| r.truth.tension_kgf > 10.0);
    twin.inject(Fault::CarriageJam);
    let healthy = twin.inputs().load_cell.get();
    for (fault, check) in [
        (LoadCellFault::Open, Box::new(|c: u16| c < 5) as Box<dyn Fn(u16) -> bool>),
        (LoadCellFault::Short, Box::new(|c: u16| c == 4095)),
        (LoadCellFault::Reversed, Box::new(|c: u16| c == 0)),
    ] {
        twin.inject(Fault::LoadCell(fault));
        run(&mut twin, 2, coast());
        let code = twin.inputs().load_cell.get();
        assert!(check(code), "{fault:?}: {code} (healthy {healthy})");
    }
}

#[test]
fn keys_are_held_for_the_scripted_time() {
    let mut twin = Twin::new(&TwinConfig::nominal(StringKind::NoString));
    twin.press(Keys::NONE.with(Key::Start), 100);
    twin.schedule_keys(300, Keys::NONE.with(Key::Up).with(Key::Down));
    twin.schedule_keys(350, Keys::NONE);
    let trace = run(&mut twin, 400, coast());
    let held = |key: Key| trace.rows.iter().filter(|r| r.inputs.keys.contains(key)).count();
    assert_eq!(held(Key::Start), 100);
    assert_eq!(held(Key::Up), 50);
    assert_eq!(held(Key::Down), 50);
    assert!(trace.rows[..100].iter().all(|r| r.inputs.keys.contains(Key::Start)));
}

#[test]
fn reference_gauge_has_the_configured_spread() {
    let mut twin = Twin::new(&quiet(StringKind::TennisSynthetic));
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.3, 0), |r| r.truth.tension_kgf > 20.0);
    twin.inject(Fault::CarriageJam);
    run(&mut twin, 1, coast());
    let truth = twin.truth().tension_kgf;
    let reads: Vec<f64> = (0..20_000).map(|_| twin.reference_gauge()).collect();
    let m = mean(reads.iter().copied());
    let sd = mean(reads.iter().map(|r| (r - m) * (r - m))).sqrt();
    assert!((m - truth).abs() < 0.001, "{m} vs {truth}");
    assert!((sd - 0.02).abs() < 0.001, "{sd}");
}

#[test]
fn tension_is_force_balanced_when_the_carriage_is_stuck() {
    // At rest with the drive coasting, the string is held by the screw's friction only if
    // it cannot back-drive it: low tensions stay, high tensions pull the carriage back.
    let config = quiet(StringKind::TennisPolyester);
    let mut twin = Twin::new(&config);
    run_until(&mut twin, 5_000, ramped(Direction::Pull, 0.4, 0), |r| r.truth.tension_kgf > 30.0);
    run(&mut twin, 3_000, coast());
    let held = twin.truth().tension_kgf;
    let k = config.mechanics;
    let (a, _) = k.friction_coefficients();
    let r = k.metres_per_radian();
    let coulomb = config.motor.coulomb_torque_nm + k.drag_torque_nm + k.slide_friction_n * r;
    // Back-drive threshold: T·r·(1 − stiction·a) = stiction·T₀ (± cogging).
    let s = k.stiction_ratio;
    let threshold = |extra: f64| (s * coulomb + extra) / (r * (1.0 - s * a)) / NEWTONS_PER_KGF;
    let cog = config.motor.cogging_torque_nm;
    println!(
        "coasting string settles at {held:.2} kgf (back-drive threshold {:.2}–{:.2})",
        threshold(-cog),
        threshold(cog)
    );
    assert!(held < 30.0);
    assert!(held > 0.7 * threshold(-cog) && held < 1.05 * threshold(cog), "{held}");
}

/// The carriage (no string) run up to `duty` and left there until steady.
fn carriage_at_speed(duty: f64) -> Twin {
    let mut twin = Twin::new(&quiet(StringKind::NoString));
    run(&mut twin, 600, ramped(Direction::Pull, duty, 200));
    twin
}

#[test]
fn a_low_duty_on_a_spinning_motor_brakes_it() {
    // Complementary switched leg: a pull-direction duty below the back-EMF ratio drives the
    // winding current backwards — braking torque — where a diode-freewheeling bridge
    // would only coast.
    let mut braked = carriage_at_speed(0.6);
    let v0 = braked.truth().carriage_mm_per_s;
    assert!(v0 > 35.0, "{v0} mm/s");
    let mut coasted = braked.clone();
    let brake = run(&mut braked, 10, |_| Outputs {
        drive: drive_at(Direction::Pull, 0.3),
        ..Outputs::default()
    });
    let coast_trace = run(&mut coasted, 10, coast());
    let torque = brake.rows.iter().map(|r| r.truth.torque_nm).fold(0.0, f64::min);
    let amps = brake.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    let v_brake = braked.truth().carriage_mm_per_s;
    let v_coast = coasted.truth().carriage_mm_per_s;
    println!(
        "from {v0:.1} mm/s: duty 0.3 for 10 ms → {v_brake:.1} mm/s (torque down to \
         {torque:.3} N·m, {amps:.1} A), coasting → {v_coast:.1} mm/s"
    );
    // Back-EMF ratio ≈ 0.58 against a duty of 0.3: the current reverses (L/R ≈ 1 ms) and
    // brakes the ≈ 394 kg of reflected inertia toward the speed that duty holds.
    assert!(torque < -0.15, "braking torque {torque}");
    assert!(brake.rows.iter().all(|r| r.truth.drive_fault.is_none()));
    // Within 10 ms it has lost a third of its speed; friction alone has barely slowed the
    // coasting carriage.
    assert!(v_brake < 0.7 * v0 && v_brake > 0.45 * v0, "{v_brake}");
    assert!(v_coast > 0.85 * v0, "{v_coast}");
    assert!(coast_trace.rows.iter().skip(1).all(|r| r.truth.torque_nm.abs() < 1e-9));
}

#[test]
fn a_hard_brake_pumps_the_bus_up_and_the_supply_diode_blocks() {
    let config = quiet(StringKind::NoString);
    let mut twin = carriage_at_speed(0.9);
    let c = config.bridge.bus_capacitance_f;
    let supply = config.bridge.bus_volts;
    let before = twin.truth();
    // Motoring: the bus sags a little below the supply (the diode conducts).
    assert!(before.bus_volts < supply && before.bus_volts > supply - 0.3, "{before:?}");
    // Brake at half the back-EMF ratio: ≈ 10 A of winding current flows back into the bus.
    let ratio = before.carriage_mm_per_s / 76.0;
    let trace = run(&mut twin, 40, |_| Outputs {
        drive: drive_at(Direction::Pull, 0.5 * ratio),
        ..Outputs::default()
    });
    let peak = trace.rows.iter().map(|r| r.truth.bus_peak_volts).fold(0.0, f64::max);
    let m = config.mechanics;
    let r = m.metres_per_radian();
    let inertia =
        config.motor.rotor_inertia_kg_m2 + m.gear_inertia_kg_m2 + m.carriage_mass_kg * r * r;
    let omega = before.motor_rpm * std::f64::consts::TAU / 60.0;
    let kinetic = 0.5 * inertia * omega * omega;
    let stored = 0.5 * c * (peak * peak - before.bus_volts * before.bus_volts);
    let after = twin.truth();
    println!(
        "brake from {:.1} to {:.1} mm/s ({kinetic:.3} J): bus {:.2} → peak {peak:.2} V \
         ({stored:.3} J into {:.0} µF), {:.2} V 40 ms later",
        before.carriage_mm_per_s,
        after.carriage_mm_per_s,
        before.bus_volts,
        c * 1e6,
        after.bus_volts
    );
    assert!(peak > supply + 3.0, "the bus must rise: {peak}");
    // Energy: the capacitor gets less than the kinetic energy (friction and copper losses).
    assert!(stored > 0.1 * kinetic && stored < kinetic, "{stored} of {kinetic}");
    // The supply cannot take it back: the bus stays up, held by the capacitor, and only the
    // auxiliary load (0.1 A → 0.1 V/ms) brings it slowly down to the supply again.
    assert!(after.bus_volts > supply + 1.0 && after.bus_volts <= peak, "{after:?}");
    run(&mut twin, 1_000, coast());
    let settled = twin.truth().bus_volts;
    assert!((settled - supply).abs() < 0.01, "{settled}");
}

#[test]
fn a_carriage_driven_back_against_a_pull_is_braked_at_the_current_limit() {
    // The carriage runs toward home at speed (≈ 10 V of back-EMF, past I_lim·R) when the
    // command turns to a light pull — what a string that back-drives a ball screw does to a
    // held carriage, and a reversal at speed. No duty of the pull table keeps the current
    // within the limit: the drive brakes through the release table at its lower edge, the
    // limit's current against the rotation (four-quadrant torque), instead of coasting.
    let mut config = quiet(StringKind::NoString);
    config.mechanics.start_mm = 150.0;
    let mut twin = Twin::new(&config);
    run(&mut twin, 300, ramped(Direction::Release, 0.45, 100));
    let v0 = twin.truth().carriage_mm_per_s;
    let coasted_before = twin.truth().drive_coasting;
    let mut coasting = twin.clone();
    let trace = run(&mut twin, 15, |_| Outputs {
        drive: drive_at(Direction::Pull, 0.05),
        ..Outputs::default()
    });
    run(&mut coasting, 15, coast());
    let torque = trace.rows.iter().map(|r| r.truth.torque_nm).fold(0.0, f64::max);
    let amps = trace.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    let (v_brake, v_coast) = (twin.truth().carriage_mm_per_s, coasting.truth().carriage_mm_per_s);
    let coasted = twin.truth().drive_coasting - coasted_before;
    println!(
        "from {v0:.1} mm/s: a 5 % pull for 15 ms → {v_brake:.1} mm/s (torque up to {torque:.3} \
         N·m, peak {amps:.2} A, {coasted} periods coasting), coasting → {v_coast:.1} mm/s"
    );
    assert!(v0 < -30.0, "{v0} mm/s");
    // Braking at the window's lower edge: the 8 A limit with the coldest winding's 0.70 Ω;
    // the nominal 0.85 Ω and a speed read from the last step interval (an upper bound while
    // the rotor slows) put ≈ 4 A through it (Kt ≈ 0.06 N·m/A): ≈ 0.24 N·m toward the pull,
    // never past the limit, never near the 12 A trip.
    assert!(torque > 0.2, "braking torque {torque}");
    assert!(amps < 9.6, "peak {amps} A");
    assert!(trace.rows.iter().all(|r| r.truth.drive_fault.is_none()));
    // The carriage has stopped running home or turned; coasting it runs on.
    assert!(v_brake > 0.3 * v0, "{v_brake}");
    assert!(v_coast < 0.7 * v0, "{v_coast}");
    assert!(coasted <= 2, "{coasted} periods coasted under the pull");
}
