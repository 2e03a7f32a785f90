//! The sensors as the converter sees them: load cell, motor current, string encoder.
//!
//! # Theory of operation
//!
//! **Load cell.** The true tension `T` (kgf) passes through the strain-gauge bar and
//! bridge, whose response is linear above a few kilograms but soft below (paper, figure
//! 21: "poor linearity below 5 kg"), modelled as
//!
//! ```text
//! T_s = T − c·F_k·(1 − e^(−T/F_k)) ,   V = V₀ + s · T_s · (1 + q · T/50)
//! ```
//!
//! with `s` the sensitivity (nominal 92 mV/kgf from `taut_core::sense::load_cell`), `V₀` the
//! zero offset, `c`, `F_k` the low-load deficit and its scale, `q` a small quadratic term.
//! The amplifier's bandwidth is a first-order low-pass. At the sampling instant white
//! noise is added, and — when the bridge is switching — a **spike**: with a fixed
//! probability per sample while the PWM runs (the sample lands in an edge's ringing) and
//! with a higher probability when a commutation happened in the PWM period before the
//! sample; its size grows with the current switched (paper, figure 22). Spikes may also
//! come in **bursts**: with a probability per switching sample a run of 1 ..= `N`
//! consecutive samples (uniform) each carries a spike of the same sign (a gate driver
//! ringing across several conversions), which a median of five passes from three on. The
//! voltage is
//! converted by the board's 12-bit converter (`AdcReference::code`; 5 V on the paper's board).
//!
//! Mains hum (`volts · sin(2π·f·t + φ)`, referred to the amplifier output) is added at
//! the sample with the noise.
//!
//! The amplifier's zero **drifts while the chain warms up** after power-up (the bridge's
//! excitation heats its gauges, the amplifier chip and board warm, and their offset drifts
//! follow): the zero moves at a rate `ṙ` at power-up and settles with the board's thermal
//! time constant `τ_w`,
//!
//! ```text
//! V_w(t) = ṙ · τ_w · (1 − e^(−t/τ_w))
//! ```
//!
//! so over the seconds of a pull it is a constant-rate ramp (within `t/2τ_w`: 3 % over a
//! 16 s pull at 3 min), and over a working day it stays bounded at `ṙ·τ_w`. `t` is the
//! chain's time since power-up (every [`LoadCell::update`], and [`LoadCell::idle`] between
//! pulls). The day's slow drift ([`crate::drift`]) adds on top.
//!
//! **Motor current.** One sample per PWM period of what the board's shunt carries
//! ([`crate::params::CurrentSensing`]): the sector's low-leg shunt (per-phase sensing: the
//! winding current, signed), or the DC-link shunt at mid on-time (the winding current while
//! the high side conducts), or the DC-link shunt behind an RC filter read at a fixed point of
//! the period (≈ duty × winding current). The amplifier adds its design offset (0 V, or
//! mid-rail for a bidirectional amplifier), gain and offset errors and noise, and its output
//! clips at the rails (a unidirectional amplifier reads negative currents as 0 V); the
//! drive gets each period's code, the tick the code of the mean of its twenty samples.
//!
//! **Bus voltage.** The divider's output plus noise is converted once per PWM period in the
//! quiet end of the period, and the ADC's hardware oversampler averages blocks of 16
//! conversions (`taut_firmware::timing`): the drive and the tick both read the last
//! complete block's rounded mean.
//!
//! **Encoder.** A wheel pressed on the string turns as the string is drawn through the
//! tension head; its quadrature counter is the string's travel times counts per mm, wrapped
//! to 16 bits.

use taut_core::drive::{LegState, Phase, SwitchPattern};
use taut_core::units::{AdcCode, AdcReference, Volts};

use crate::motor::PeriodResult;
use crate::params::{
    BusSenseParams, CurrentSenseParams, CurrentSensing, DcLinkSampling, LoadCellParams,
};
use crate::rng::SimRng;

/// A voltage as the core's Q15.16 `Volts` (rounded to the nearest 2⁻¹⁶ V, saturating).
#[must_use]
pub fn volts(v: f64) -> Volts {
    let bits = (v * 65_536.0).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX));
    Volts::from_bits(bits as i32)
}

/// The ADC code a voltage converts to on the paper's 5 V converter (clamped to 0 ..= 4095).
#[must_use]
pub fn adc(v: f64) -> AdcCode {
    FIVE_VOLTS.code(volts(v))
}

/// The paper's board's converter: 12 bits, 5 V.
#[allow(clippy::panic, reason = "evaluated when compiled: a refused reference stops the build")]
pub const FIVE_VOLTS: AdcReference = match AdcReference::from_millivolts(5_000) {
    Some(reference) => reference,
    None => panic!("5 V is a converter reference"),
};

/// A wiring fault of the load cell.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum LoadCellFault {
    /// Bridge disconnected: the amplifier output rests at 0 V.
    Open,
    /// Bridge or amplifier shorted to its supply: full scale.
    Short,
    /// Bridge signal wires swapped: the output moves the wrong way from its offset.
    Reversed,
}

/// The load-cell chain's state: the amplifier's filtered output.
#[derive(Clone, Debug)]
pub struct LoadCell {
    params: LoadCellParams,
    /// The converter the chain feeds.
    reference: AdcReference,
    filtered: f64,
    /// Samples of the present burst still to come.
    burst_left: u32,
    /// The present burst's sign.
    burst_sign: f64,
    /// An injected burst: samples still to come and the volts each carries.
    injected: (u32, f64),
    /// The day's drift of the output (zero with temperature, creep), V ([`crate::drift`]).
    drift_volts: f64,
    /// Time since power-up, s: the warm-up's clock.
    powered_s: f64,
}

impl LoadCell {
    /// A chain at rest with no load, into a converter of `reference`.
    #[must_use]
    pub fn new(params: &LoadCellParams, reference: AdcReference) -> Self {
        let mut cell = Self {
            params: *params,
            reference,
            filtered: 0.0,
            burst_left: 0,
            burst_sign: 1.0,
            injected: (0, 0.0),
            drift_volts: 0.0,
            powered_s: 0.0,
        };
        cell.filtered = cell.static_volts(0.0);
        cell
    }

    /// The settled amplifier output for tension `tension_kgf` (no noise).
    #[must_use]
    pub fn static_volts(&self, tension_kgf: f64) -> f64 {
        let p = &self.params;
        let t = tension_kgf.max(0.0);
        let scale = p.low_load_scale_kgf.max(1e-9);
        let seated = t - p.low_load_deficit * scale * (1.0 - (-t / scale).exp());
        p.zero_volts
            + self.drift_volts
            + self.warm_up_volts()
            + p.volts_per_kgf * seated * (1.0 + p.quadratic_at_50_kgf * t / 50.0)
    }

    /// How far the amplifier's zero has moved since power-up as the chain warms, V.
    #[must_use]
    pub fn warm_up_volts(&self) -> f64 {
        let p = &self.params;
        if p.zero_drift_volts_per_s == 0.0 {
            return 0.0;
        }
        let settle = p.zero_drift_settle_s;
        p.zero_drift_volts_per_s * settle * -(-self.powered_s / settle).exp_m1()
    }

    /// Lets `seconds` pass without a sample (the minutes between pulls): the chain keeps
    /// warming up.
    pub fn idle(&mut self, seconds: f64) {
        self.powered_s += seconds.max(0.0);
    }

    /// Sets the day's drift of the output, kgf of the nominal sensitivity: the amplifier's
    /// output follows it through its bandwidth like any change of load.
    pub fn set_drift_kgf(&mut self, kgf: f64) {
        self.drift_volts = kgf * self.params.volts_per_kgf;
    }

    /// Adds `volts` to each of the next `samples` samples (a burst placed by a test; it
    /// draws nothing from the random stream).
    pub fn inject_burst(&mut self, samples: u32, volts: f64) {
        self.injected = (samples, volts);
    }

    /// Advances the amplifier's low-pass by `dt` toward the output for `tension_kgf`.
    pub fn update(&mut self, tension_kgf: f64, dt: f64) {
        self.powered_s += dt;
        let target = self.static_volts(tension_kgf);
        let alpha = 1.0 - (-dt * core::f64::consts::TAU * self.params.bandwidth_hz).exp();
        self.filtered += (target - self.filtered) * alpha;
    }

    /// The amplifier output now, before noise, V.
    #[must_use]
    pub const fn output_volts(&self) -> f64 {
        self.filtered
    }

    /// The mains hum at time `time_s`, V.
    #[must_use]
    pub fn hum_volts(&self, time_s: f64) -> f64 {
        let hum = &self.params.hum;
        if hum.volts > 0.0 {
            let phase =
                core::f64::consts::TAU * hum.frequency_hz * time_s + hum.phase_deg.to_radians();
            hum.volts * phase.sin()
        } else {
            0.0
        }
    }

    /// One converter sample at `time_s`: the filtered output plus noise, mains hum and a
    /// possible switching spike or a burst's. `switching` says the PWM ran in the last
    /// period, `commutated` that a commutation happened in it, `amps` the current switched.
    /// The random stream is drawn for bursts only when they are configured, so a machine
    /// without them sees the same noise as before they existed.
    pub fn sample(
        &mut self,
        rng: &mut SimRng,
        time_s: f64,
        switching: bool,
        commutated: bool,
        amps: f64,
        fault: Option<LoadCellFault>,
    ) -> AdcCode {
        let p = &self.params;
        let mut v = self.filtered + rng.gaussian(p.noise_volts);
        if p.hum.volts > 0.0 {
            v += self.hum_volts(time_s);
        }
        let spike_probability = match (switching, commutated) {
            (_, true) => p.spikes.commutation_probability,
            (true, false) => p.spikes.pwm_probability,
            (false, false) => 0.0,
        };
        if rng.chance(spike_probability) {
            let size = p.spikes.base_volts + p.spikes.volts_per_amp * amps.abs();
            v += rng.sign() * size * rng.range(0.3, 1.0);
        }
        if p.spikes.burst_probability > 0.0 && p.spikes.burst_samples_max > 0 {
            if self.burst_left == 0 && switching && rng.chance(p.spikes.burst_probability) {
                self.burst_left = rng.below(p.spikes.burst_samples_max).saturating_add(1);
                self.burst_sign = rng.sign();
            }
            if self.burst_left > 0 {
                self.burst_left = self.burst_left.saturating_sub(1);
                let size = p.spikes.base_volts + p.spikes.volts_per_amp * amps.abs();
                v += self.burst_sign * size * rng.range(0.3, 1.0);
            }
        }
        if self.injected.0 > 0 {
            self.injected.0 = self.injected.0.saturating_sub(1);
            v += self.injected.1;
        }
        let adc = |v: f64| self.reference.code(volts(v));
        match fault {
            None => adc(v),
            Some(LoadCellFault::Open) => adc(rng.gaussian(p.noise_volts).abs()),
            Some(LoadCellFault::Short) => AdcCode::MAX,
            Some(LoadCellFault::Reversed) => adc(2.0 * p.zero_volts - v),
        }
    }
}

/// The current shunt(s) and amplifier, with the RC filter's state for a filtered DC link.
///
/// Currents are handled as the amplifier's output referred back to amperes ("output
/// amperes": volts / design gain), so the nominal board's arithmetic is the one it always
/// was.
#[derive(Clone, Copy, Debug)]
pub struct CurrentSense {
    params: CurrentSenseParams,
    /// The converter the amplifier feeds.
    reference: AdcReference,
    volts_per_amp: f64,
    /// The design offset in output amperes (0, or mid-rail / gain).
    offset_amps: f64,
    /// The rails in output amperes: the converter's reference / gain.
    full_scale_amps: f64,
    /// The RC filter's output, output amperes (filtered DC link only).
    filtered: f64,
    /// The filter's output at the last period's sampling instant, output amperes.
    last_filtered_sample: f64,
}

impl CurrentSense {
    /// The sensor with its design gain and offset, perturbed by the configured errors, its
    /// filter (if any) settled at zero current, into a converter of `reference`.
    #[must_use]
    pub fn new(params: &CurrentSenseParams, reference: AdcReference) -> Self {
        let volts_per_amp = params.volts_per_amp;
        let offset_amps = params.offset_volts / volts_per_amp;
        let full_scale = f64::from(reference.millivolts()) / 1_000.0;
        let mut sense = Self {
            params: *params,
            reference,
            volts_per_amp,
            offset_amps,
            full_scale_amps: full_scale / volts_per_amp,
            filtered: 0.0,
            last_filtered_sample: 0.0,
        };
        sense.filtered = sense.amplify(0.0);
        sense.last_filtered_sample = sense.filtered;
        sense
    }

    /// The amplifier's output for a shunt current `amps`, without noise, clipped at the
    /// rails, in output amperes.
    fn amplify(&self, amps: f64) -> f64 {
        let p = &self.params;
        (amps * (1.0 + p.gain_error) + p.offset_amps + self.offset_amps)
            .clamp(0.0, self.full_scale_amps)
    }

    /// What one sample reads, in output amperes (noise and offsets included, clipped at the
    /// rails: a unidirectional amplifier reads negative currents as zero): `true_amps` is
    /// the shunt's current at the sampling instant.
    pub fn measure(&self, rng: &mut SimRng, true_amps: f64) -> f64 {
        let p = &self.params;
        (true_amps * (1.0 + p.gain_error)
            + p.offset_amps
            + rng.gaussian(p.noise_amps)
            + self.offset_amps)
            .clamp(0.0, self.full_scale_amps)
    }

    /// The output at zero current without noise, in output amperes: what the converter holds
    /// before the first PWM period (the amplifier's offset, mid-rail on a bidirectional board).
    #[must_use]
    pub fn at_rest(&self) -> f64 {
        (self.params.offset_amps + self.offset_amps).clamp(0.0, self.full_scale_amps)
    }

    /// The current the board's shunt carries at its sampling instant in the period just
    /// solved (see [`CurrentSensing`]), before the amplifier, A — except for a filtered DC
    /// link, whose filter this advances and whose output it returns (`None` then).
    fn shunt_amps(
        &mut self,
        result: &PeriodResult,
        pattern: SwitchPattern,
        period_s: f64,
    ) -> Option<f64> {
        match self.params.sensing {
            CurrentSensing::DcLink(DcLinkSampling::MidOnTime) => {
                Some(if result.on_time > 0.0 { result.on_bus_current } else { 0.0 })
            }
            CurrentSensing::PerPhaseLowSide => {
                // The low leg's shunt carries the winding current out of the motor: minus
                // the phase current (positive into the motor) at mid on-time.
                let low = Phase::ALL
                    .iter()
                    .zip(result.on_mean_current)
                    .filter(|(phase, _)| pattern.leg(**phase) == LegState::Low)
                    .map(|(_, i)| -i)
                    .sum::<f64>();
                Some(if pattern.count(LegState::Low) > 0 { low } else { 0.0 })
            }
            CurrentSensing::DcLink(DcLinkSampling::Filtered { time_constant_s, sample_phase }) => {
                self.filter_period(result, period_s, time_constant_s, sample_phase);
                None
            }
        }
    }

    /// Advances the RC filter over the parts of the period (each part's mean bus current
    /// through the amplifier, exact for a piecewise-constant input) and leaves in
    /// `self.filtered` its output at `phase` of the period; the state carried to the next
    /// period is the one at the period's end.
    fn filter_period(&mut self, result: &PeriodResult, period_s: f64, tau: f64, phase: f64) {
        let sample_at = phase * period_s;
        let mut y = self.filtered;
        let mut t = 0.0;
        let mut sampled = None;
        for part in result.bus_segments.iter().filter(|part| part.duration > 0.0) {
            let input = self.amplify(part.charge / part.duration);
            if sampled.is_none() && sample_at < t + part.duration {
                let into = (sample_at - t).max(0.0);
                sampled = Some(input + (y - input) * (-into / tau).exp());
            }
            y = input + (y - input) * (-part.duration / tau).exp();
            t += part.duration;
        }
        // Parts shorter than the period (never, but float rounding) leave the tail at zero
        // input.
        if t < period_s {
            let input = self.amplify(0.0);
            if sampled.is_none() {
                let into = (sample_at - t).max(0.0);
                sampled = Some(input + (y - input) * (-into / tau).exp());
            }
            y = input + (y - input) * (-(period_s - t) / tau).exp();
        }
        self.filtered = y;
        self.last_filtered_sample = sampled.unwrap_or(y);
    }

    /// One PWM period's sample, in output amperes: what the board's shunt carried (see
    /// [`CurrentSensing`]) through the amplifier, with noise. `open`: the amplifier output
    /// is lost and reads 0 V (the filter still runs, no noise is drawn).
    pub fn sample_period(
        &mut self,
        rng: &mut SimRng,
        result: &PeriodResult,
        pattern: SwitchPattern,
        period_s: f64,
        open: bool,
    ) -> f64 {
        let shunt = self.shunt_amps(result, pattern, period_s);
        if open {
            return 0.0;
        }
        match shunt {
            Some(amps) => self.measure(rng, amps),
            None => (self.last_filtered_sample + rng.gaussian(self.params.noise_amps))
                .clamp(0.0, self.full_scale_amps),
        }
    }

    /// The converter code at zero current without noise.
    #[must_use]
    pub fn rest_code(&self) -> AdcCode {
        self.code(self.at_rest())
    }

    /// The converter code for an amplifier output in output amperes.
    #[must_use]
    pub fn code(&self, measured_amps: f64) -> AdcCode {
        self.reference.code(volts(measured_amps * self.volts_per_amp))
    }

    /// The current a code stands for with this board's design gain and offset, A (what a
    /// core configured for the board reads; the inverse of [`CurrentSense::code`] up to
    /// the converter's resolution and the sensor's errors).
    #[must_use]
    pub fn amps_of(&self, code: AdcCode) -> f64 {
        let reference = f64::from(self.reference.millivolts()) / 1_000.0;
        f64::from(code.get()) * reference / 4096.0 / self.volts_per_amp - self.offset_amps
    }
}

/// The bus-voltage divider and the ADC's hardware oversampler.
#[derive(Clone, Copy, Debug)]
pub struct BusVoltageSense {
    params: BusSenseParams,
    /// The converter the divider feeds.
    reference: AdcReference,
    sum: u32,
    count: u32,
    register: AdcCode,
}

impl BusVoltageSense {
    /// The divider into a converter of `reference`, its oversampler's result register
    /// holding the code of `bus_volts`.
    #[must_use]
    pub fn new(params: &BusSenseParams, bus_volts: f64, reference: AdcReference) -> Self {
        let register = reference.code(volts(bus_volts / params.divider_ratio));
        Self { params: *params, reference, sum: 0, count: 0, register }
    }

    /// One conversion of the bus at `bus_volts` (the period's quiet end); every
    /// [`BusSenseParams::OVERSAMPLING`] conversions the result register takes their
    /// rounded mean.
    pub fn convert(&mut self, rng: &mut SimRng, bus_volts: f64) {
        let p = &self.params;
        let code =
            self.reference.code(volts(bus_volts / p.divider_ratio + rng.gaussian(p.noise_volts)));
        self.sum = self.sum.saturating_add(u32::from(code.get()));
        self.count = self.count.saturating_add(1);
        if self.count >= BusSenseParams::OVERSAMPLING {
            let half = BusSenseParams::OVERSAMPLING / 2;
            let mean = self.sum.saturating_add(half) / BusSenseParams::OVERSAMPLING;
            self.register = AdcCode::new(u16::try_from(mean).unwrap_or(u16::MAX));
            self.sum = 0;
            self.count = 0;
        }
    }

    /// The result register: what the firmware reads.
    #[must_use]
    pub const fn register(&self) -> AdcCode {
        self.register
    }

    /// The bus voltage a code stands for with this divider, V.
    #[must_use]
    pub fn volts_of(&self, code: AdcCode) -> f64 {
        let reference = f64::from(self.reference.millivolts()) / 1_000.0;
        f64::from(code.get()) * reference / 4096.0 * self.params.divider_ratio
    }
}

#[cfg(test)]
mod tests {

    use super::*;

    #[test]
    fn ten_kgf_reads_about_920_mv_above_zero() {
        let p = LoadCellParams::nominal();
        let cell = LoadCell::new(&p, FIVE_VOLTS);
        let above_zero = cell.static_volts(10.0) - p.zero_volts;
        // 920 mV nominal, less the seated-deficit offset (c·F_k·92 mV ≈ 69 mV).
        assert!((above_zero - 0.92).abs() < 0.08, "{above_zero}");
        // Slope between 10 and 40 kgf is the nominal sensitivity within the quadratic term.
        let slope = (cell.static_volts(40.0) - cell.static_volts(10.0)) / 30.0;
        assert!((slope - 0.092).abs() < 0.0005, "{slope}");
    }

    #[test]
    fn low_loads_are_non_linear_high_loads_are_not() {
        let cell = LoadCell::new(&LoadCellParams::nominal(), FIVE_VOLTS);
        let line = |t: f64| {
            let a = cell.static_volts(20.0);
            let b = cell.static_volts(30.0);
            a + (b - a) * (t - 20.0) / 10.0
        };
        let error_kgf = |t: f64| (cell.static_volts(t) - line(t)).abs() / 0.092;
        assert!(error_kgf(1.0) > 0.3, "{}", error_kgf(1.0));
        assert!(error_kgf(12.0) < 0.05, "{}", error_kgf(12.0));
    }

    #[test]
    fn core_scale_reads_the_twin_code_back() {
        let mut cell = LoadCell::new(&LoadCellParams::nominal(), FIVE_VOLTS);
        for _ in 0..100 {
            cell.update(25.0, 1e-3);
        }
        let mut rng = SimRng::new(1);
        let code = cell.sample(&mut rng, 0.0, false, false, 0.0, None);
        let kgf =
            taut_core::board::paper().expect("valid").load_cell().to_kgf(code).0.to_num::<f64>();
        // Nominal scale, uncorrected: within the deficit offset (≈ 0.75 kgf) + noise.
        assert!((kgf - 25.0).abs() < 1.0, "{kgf}");
    }

    #[test]
    fn a_warming_amplifier_moves_the_zero_at_its_rate_under_a_constant_load() {
        let rate = 0.1e-3;
        let p = LoadCellParams { zero_drift_volts_per_s: rate, ..LoadCellParams::nominal() };
        let mut cell = LoadCell::new(&p, FIVE_VOLTS);
        let mut settled = LoadCell::new(&LoadCellParams::nominal(), FIVE_VOLTS);
        let dt = 1e-3;
        let run = |cell: &mut LoadCell, seconds: f64| {
            for _ in 0..(seconds / dt).round() as u32 {
                cell.update(20.0, dt);
            }
            cell.output_volts()
        };
        // 20 kgf held: after a second (the amplifier's low-pass long settled) and ten more.
        let (start, plain_start) = (run(&mut cell, 1.0), run(&mut settled, 1.0));
        let (end, plain_end) = (run(&mut cell, 10.0), run(&mut settled, 10.0));
        assert!((plain_end - plain_start).abs() < 1e-12, "a settled chain holds its reading");
        let slope = (end - start) / 10.0;
        assert!((slope / rate - 1.0).abs() < 0.04, "{slope} V/s vs {rate}");
        // The reading moved by the ramp alone (1.1 mV, 0.012 kgf at 92 mV/kgf), behind it by
        // the amplifier's low-pass (a few nanovolts at 500 Hz).
        let lag = cell.warm_up_volts() - (end - plain_end);
        assert!(lag > 0.0 && lag < 1e-8, "{lag}");
        assert!((cell.warm_up_volts() - rate * 11.0).abs() < 0.04 * rate * 11.0);
        // Between pulls it keeps warming, and settles at rate × τ.
        cell.idle(3_600.0);
        let bound = rate * p.zero_drift_settle_s;
        assert!((cell.warm_up_volts() - bound).abs() < 1e-6 * bound, "{}", cell.warm_up_volts());
        // A negative rate drifts down the same way.
        let cooling = LoadCellParams { zero_drift_volts_per_s: -rate, ..p };
        let mut down = LoadCell::new(&cooling, FIVE_VOLTS);
        let (a, b) = (run(&mut down, 1.0), run(&mut down, 10.0));
        assert!(((b - a) / 10.0 + slope).abs() < 1e-12);
    }

    #[test]
    fn faults_read_as_wired() {
        let mut cell = LoadCell::new(&LoadCellParams::nominal(), FIVE_VOLTS);
        let mut rng = SimRng::new(2);
        assert!(
            cell.sample(&mut rng, 0.0, false, false, 0.0, Some(LoadCellFault::Open)).get() < 10
        );
        assert_eq!(
            cell.sample(&mut rng, 0.0, false, false, 0.0, Some(LoadCellFault::Short)),
            AdcCode::MAX
        );
    }

    #[test]
    fn current_code_uses_the_core_gain() {
        let sense = CurrentSense::new(&CurrentSenseParams::nominal(), FIVE_VOLTS);
        let code = sense.code(5.0);
        let amps = taut_core::sense::current::amps(code).0.to_num::<f64>();
        assert!((amps - 5.0).abs() < 0.01, "{amps}");
    }
}
