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
//! sample; its size grows with the current switched (paper, figure 22). The voltage is
//! converted by the 12-bit, 5 V converter (`AdcCode::from_volts`).
//!
//! **Motor current.** The bus shunt is sampled in the middle of each PWM on-time (the
//! average bus current over the on-time), scaled by `taut_core::sense::current`'s
//! 0.2 V/A with a gain error and offset, plus noise; the drive gets each period's sample,
//! the tick gets their average. A low-side shunt amplifier is unipolar: negative currents
//! read zero.
//!
//! **Encoder.** A wheel pressed on the string turns as the string is drawn through the
//! tension head; its quadrature counter is the string's travel times counts per mm, wrapped
//! to 16 bits.

use taut_core::sense::current::VOLTS_PER_AMP;
use taut_core::units::{AdcCode, Volts};

use crate::params::{CurrentSenseParams, LoadCellParams};
use crate::rng::SimRng;

/// A voltage as the core's Q15.16 `Volts` (rounded to the nearest 2⁻¹⁶ V, saturating).
#[must_use]
pub fn volts(v: f64) -> Volts {
    let bits = (v * 65_536.0).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX));
    Volts::from_bits(bits as i32)
}

/// The ADC code a voltage converts to (`AdcCode::from_volts`, clamped to 0 ..= 4095).
#[must_use]
pub fn adc(v: f64) -> AdcCode {
    AdcCode::from_volts(volts(v))
}

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
    filtered: f64,
}

impl LoadCell {
    /// A chain at rest with no load.
    #[must_use]
    pub fn new(params: &LoadCellParams) -> Self {
        let mut cell = Self { params: *params, filtered: 0.0 };
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
        p.zero_volts + p.volts_per_kgf * seated * (1.0 + p.quadratic_at_50_kgf * t / 50.0)
    }

    /// Advances the amplifier's low-pass by `dt` toward the output for `tension_kgf`.
    pub fn update(&mut self, tension_kgf: f64, dt: f64) {
        let target = self.static_volts(tension_kgf);
        let alpha = 1.0 - (-dt * core::f64::consts::TAU * self.params.bandwidth_hz).exp();
        self.filtered += (target - self.filtered) * alpha;
    }

    /// The amplifier output now, before noise, V.
    #[must_use]
    pub const fn output_volts(&self) -> f64 {
        self.filtered
    }

    /// One converter sample: the filtered output plus noise and a possible switching spike.
    /// `switching` says the PWM ran in the last period, `commutated` that a commutation
    /// happened in it, `amps` the current switched.
    pub fn sample(
        &self,
        rng: &mut SimRng,
        switching: bool,
        commutated: bool,
        amps: f64,
        fault: Option<LoadCellFault>,
    ) -> AdcCode {
        let p = &self.params;
        let mut v = self.filtered + rng.gaussian(p.noise_volts);
        let spike_probability = match (switching, commutated) {
            (_, true) => p.spikes.commutation_probability,
            (true, false) => p.spikes.pwm_probability,
            (false, false) => 0.0,
        };
        if rng.chance(spike_probability) {
            let size = p.spikes.base_volts + p.spikes.volts_per_amp * amps.abs();
            v += rng.sign() * size * rng.range(0.3, 1.0);
        }
        match fault {
            None => adc(v),
            Some(LoadCellFault::Open) => adc(rng.gaussian(p.noise_volts).abs()),
            Some(LoadCellFault::Short) => AdcCode::MAX,
            Some(LoadCellFault::Reversed) => adc(2.0 * p.zero_volts - v),
        }
    }
}

/// The current shunt amplifier.
#[derive(Clone, Copy, Debug)]
pub struct CurrentSense {
    params: CurrentSenseParams,
    volts_per_amp: f64,
}

impl CurrentSense {
    /// The sensor with `taut_core`'s gain, perturbed by the configured error.
    #[must_use]
    pub fn new(params: &CurrentSenseParams) -> Self {
        Self { params: *params, volts_per_amp: VOLTS_PER_AMP.to_num::<f64>() }
    }

    /// What one sample reads, in amperes before conversion (noise and offset included,
    /// negative currents clamp to zero): `true_amps` is the bus current over the on-time.
    pub fn measure(&self, rng: &mut SimRng, true_amps: f64) -> f64 {
        let p = &self.params;
        (true_amps * (1.0 + p.gain_error) + p.offset_amps + rng.gaussian(p.noise_amps)).max(0.0)
    }

    /// The converter code for a measured current.
    #[must_use]
    pub fn code(&self, measured_amps: f64) -> AdcCode {
        adc(measured_amps * self.volts_per_amp)
    }
}

#[cfg(test)]
mod tests {
    use taut_core::sense::load_cell::LoadCellScale;

    use super::*;

    #[test]
    fn ten_kgf_reads_about_920_mv_above_zero() {
        let p = LoadCellParams::nominal();
        let cell = LoadCell::new(&p);
        let above_zero = cell.static_volts(10.0) - p.zero_volts;
        // 920 mV nominal, less the seated-deficit offset (c·F_k·92 mV ≈ 69 mV).
        assert!((above_zero - 0.92).abs() < 0.08, "{above_zero}");
        // Slope between 10 and 40 kgf is the nominal sensitivity within the quadratic term.
        let slope = (cell.static_volts(40.0) - cell.static_volts(10.0)) / 30.0;
        assert!((slope - 0.092).abs() < 0.0005, "{slope}");
    }

    #[test]
    fn low_loads_are_non_linear_high_loads_are_not() {
        let cell = LoadCell::new(&LoadCellParams::nominal());
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
        let mut cell = LoadCell::new(&LoadCellParams::nominal());
        for _ in 0..100 {
            cell.update(25.0, 1e-3);
        }
        let mut rng = SimRng::new(1);
        let code = cell.sample(&mut rng, false, false, 0.0, None);
        let kgf = LoadCellScale::NOMINAL.to_kgf(code).0.to_num::<f64>();
        // Nominal scale, uncorrected: within the deficit offset (≈ 0.75 kgf) + noise.
        assert!((kgf - 25.0).abs() < 1.0, "{kgf}");
    }

    #[test]
    fn faults_read_as_wired() {
        let cell = LoadCell::new(&LoadCellParams::nominal());
        let mut rng = SimRng::new(2);
        assert!(cell.sample(&mut rng, false, false, 0.0, Some(LoadCellFault::Open)).get() < 10);
        assert_eq!(
            cell.sample(&mut rng, false, false, 0.0, Some(LoadCellFault::Short)),
            AdcCode::MAX
        );
    }

    #[test]
    fn current_code_uses_the_core_gain() {
        let sense = CurrentSense::new(&CurrentSenseParams::nominal());
        let code = sense.code(5.0);
        let amps = taut_core::sense::current::amps(code).0.to_num::<f64>();
        assert!((amps - 5.0).abs() < 0.01, "{amps}");
    }
}
