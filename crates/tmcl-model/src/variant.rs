//! Where models differ by more than numbers: units and kinematics, the reference-search mode set, the
//! motor driver and the encoder. Each is a small enum the model picks and the firmware matches on.

/// How the motion parameters are scaled and how far positions count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kinematics {
    /// Velocities in microsteps per second (pps), accelerations in pps per second, positions as 32-bit
    /// wrapping counters (PD28-1021 manual chapter 4 Table 15: AP 0–5, 130; §3.7.4).
    Pps,
    /// The TMC428 generation (PDx-113 manual chapter 6, the TMC428 datasheet): a velocity `v` of 0..2047
    /// is `clock · v / (2^pulse_div · 2048 · 32)` microsteps per second, an acceleration `a` of 0..2047 is
    /// `clock² · a / 2^(pulse_div + ramp_div + 29)` microsteps per second², with the divisors in the
    /// [`crate::param::Setting::PulseDivisor`] and [`crate::param::Setting::RampDivisor`] parameters;
    /// positions are 24-bit wrapping counters.
    Tmc428 {
        /// The TMC428's clock in Hz (16 MHz on the PDx-113).
        clock_hz: u32,
    },
}

impl Kinematics {
    /// The width of the position counter in bits (the counters wrap around at it).
    pub const fn position_bits(self) -> u32 {
        match self {
            Kinematics::Pps => 32,
            Kinematics::Tmc428 { .. } => 24,
        }
    }

    /// Velocity `v` (the model's unit, signed) in microsteps per second, given the pulse divisor.
    pub fn velocity_to_pps(self, v: i32, pulse_div: i32) -> i32 {
        match self {
            Kinematics::Pps => v,
            Kinematics::Tmc428 { clock_hz } => {
                let shift = 16 + pulse_div.clamp(0, 13) as u32; // 2048 · 32 = 2^16
                ((i64::from(clock_hz) * i64::from(v)) >> shift) as i32
            }
        }
    }

    /// The inverse of [`Kinematics::velocity_to_pps`], rounded toward zero.
    pub fn pps_to_velocity(self, pps: i32, pulse_div: i32) -> i32 {
        match self {
            Kinematics::Pps => pps,
            Kinematics::Tmc428 { clock_hz } => {
                let shift = 16 + pulse_div.clamp(0, 13) as u32;
                ((i64::from(pps) << shift) / i64::from(clock_hz.max(1))) as i32
            }
        }
    }

    /// Acceleration `a` (the model's unit) in microsteps per second², at least 1 for a non-zero `a`.
    pub fn acceleration_to_pps2(self, a: i32, pulse_div: i32, ramp_div: i32) -> i32 {
        match self {
            Kinematics::Pps => a,
            Kinematics::Tmc428 { clock_hz } => {
                let shift = 29 + pulse_div.clamp(0, 13) as u32 + ramp_div.clamp(0, 13) as u32;
                let f2 = u128::from(clock_hz) * u128::from(clock_hz);
                let pps2 = (f2 * u128::from(a.max(0) as u32)) >> shift;
                (pps2.min(i32::MAX as u128) as i32).max(i32::from(a > 0))
            }
        }
    }
}

/// Which reference-search modes AP 193 takes and what each does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceModes {
    /// Modes 1–8, +64 (modes 1–4: the right switch instead of the left), +128 (modes 5–8: inverted home
    /// switch), PD28-1021 manual §7.1 Table 21.
    Pd28,
    /// The TMC428 generation's three modes: 1 = left switch only, 2 = right switch, then left, 3 = right
    /// switch, then the reference (home) switch (the TMCM-142 and PDx-113 sibling manuals' AP 193).
    Tmc428,
}

/// The motor driver behind the step generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Driver {
    /// TMC262 with stallGuard2, coolStep and its chopper (PD28-1021 manual §1.2, chapter 4).
    Tmc262,
    /// TMC428 motion controller with a TMC246/249 driver chain on SPI (PDx-113 manual chapter 1).
    Tmc428Tmc24x,
    /// A closed-loop driver that corrects the rotor from its encoder (TMCM-1310 manual chapter 1).
    ClosedLoop,
}

/// What kind of encoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncoderKind {
    /// A magnetic absolute single-turn sensor counting from its zero point (the PD28-1021's sensOstep,
    /// manual §6.2).
    SensOstep,
    /// An incremental A/B/N encoder.
    Abn,
}

/// The encoder of a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Encoder {
    /// What kind.
    pub kind: EncoderKind,
    /// Counts per motor revolution (1024 on the PD28-1021, manual §6.2).
    pub counts_per_rev: u32,
}
