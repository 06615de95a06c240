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
    /// positions are 24-bit wrapping counters. The firmware's ramp runs in whole microsteps per second,
    /// so above a pulse divisor of 7 (one unit below one microstep per second) a velocity reads back
    /// within one microstep per second of what was written.
    Tmc428 {
        /// The TMC428's clock in Hz (16 MHz on the PDx-113).
        clock_hz: u32,
    },
}

impl Kinematics {
    /// Whether velocities and accelerations are TMC428/TMC429 units ([`Kinematics::Tmc428`]).
    pub const fn is_tmc428(self) -> bool {
        matches!(self, Kinematics::Tmc428 { .. })
    }

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
                ((i64::from(clock_hz) * i64::from(v)) / (1i64 << shift)) as i32 // toward zero, both ways
            }
        }
    }

    /// The inverse of [`Kinematics::velocity_to_pps`], rounded to the nearest unit (so that a velocity
    /// reads back as it was written).
    pub fn pps_to_velocity(self, pps: i32, pulse_div: i32) -> i32 {
        match self {
            Kinematics::Pps => pps,
            Kinematics::Tmc428 { clock_hz } => {
                let shift = 16 + pulse_div.clamp(0, 13) as u32;
                let clock = i64::from(clock_hz.max(1));
                let scaled = i64::from(pps) << shift;
                ((scaled + scaled.signum() * clock / 2) / clock) as i32
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

/// What command 135 (get application status) answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AppStatusReply {
    /// Types 0–3: mode, wait flag and pointer packed, the accumulator or the X register (PD28-1021 manual
    /// §3.7.38, Table 13); another type is status 3.
    Typed,
    /// The state alone, 0 stop, 1 run, 2 step, 3 reset, whatever the type byte (PDx-113 manual §5.5: type,
    /// motor/bank and value "don't care").
    Plain,
}

/// Which global parameter banks (SGP/GGP/STGP/RSGP/AGP) a model has, one bit per bank number 0..=7.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GlobalBanks(pub u8);

impl GlobalBanks {
    /// Banks 0, 2 and 3 (PD28-1021 manual chapter 5: bank 1 "normally not available").
    pub const ARM: GlobalBanks = GlobalBanks(0b1101);
    /// Banks 0, 1 and 2 and no bank 3 (PDx-113 manual §5.7.9: "only bank 0 and 1 are used for global
    /// parameters, and bank 2 is used for user variables"; no interrupts).
    pub const TMC428: GlobalBanks = GlobalBanks(0b0111);

    /// Whether the model has bank `bank`.
    pub const fn has(self, bank: u8) -> bool {
        bank < 8 && self.0 & (1 << bank) != 0
    }
}

/// The motor driver behind the step generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Driver {
    /// TMC262 with stallGuard2, coolStep and its chopper (PD28-1021 manual §1.2, chapter 4).
    Tmc262,
    /// TMC428 motion controller with a TMC246/249 driver chain on SPI (PDx-113 manual chapter 1).
    Tmc428Tmc24x,
}

/// What kind of encoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncoderKind {
    /// A magnetic absolute single-turn sensor counting from its zero point (the PD28-1021's sensOstep,
    /// manual §6.2).
    SensOstep,
    /// An incremental A/B/N encoder (TMCM-1310 manual chapter 1).
    Abn,
    /// An absolute single-turn encoder on SSI (TMCM-1310 manual chapter 1): it reports the angle within
    /// one revolution; the firmware counts the turns.
    Ssi,
}

/// The encoder of a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Encoder {
    /// What kind.
    pub kind: EncoderKind,
    /// Counts per motor revolution (1024 on the PD28-1021, manual §6.2).
    pub counts_per_rev: u32,
}

/// Where the closed loop gets its encoder settings: a closed-loop model sets the encoder's counts per
/// revolution and the motor's full steps in parameters (TMCM-1311 manual p.82: AP 210 and AP 202), an
/// open-loop one has a fixed encoder and a prescaler (PD28-1021 manual §6.2: AP 210).
pub const fn is_closed_loop(axis: &crate::Table) -> bool {
    axis.has(crate::Setting::ClosedLoop)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TMC428: Kinematics = Kinematics::Tmc428 { clock_hz: 16_000_000 };

    #[test]
    fn pps_is_the_identity() {
        assert_eq!(Kinematics::Pps.velocity_to_pps(-51200, 3), -51200);
        assert_eq!(Kinematics::Pps.pps_to_velocity(51200, 3), 51200);
        assert_eq!(Kinematics::Pps.acceleration_to_pps2(51200, 3, 4), 51200);
        assert_eq!(Kinematics::Pps.position_bits(), 32);
    }

    #[test]
    fn tmc428_velocities_round_trip() {
        // 16 MHz · v / (2^pd · 2048 · 32): v = 2047 at pd 0 is 499 755 microsteps/s.
        assert_eq!(TMC428.velocity_to_pps(2047, 0), 499_755);
        assert_eq!(TMC428.velocity_to_pps(1000, 3), 30_517);
        assert_eq!(TMC428.velocity_to_pps(-1000, 3), -30_517, "symmetric: toward zero");
        // Exact while one unit is at least one microstep per second (pulse divisor ≤ 7); above, within
        // one microstep per second (the firmware's ramp runs in whole microsteps per second).
        for pd in 0..=13 {
            for v in [-2047, -1000, -1, 0, 1, 7, 1000, 2047] {
                let back = TMC428.pps_to_velocity(TMC428.velocity_to_pps(v, pd), pd);
                if pd <= 7 {
                    assert_eq!(back, v, "v {v} pd {pd}");
                } else {
                    let one_pps = (1 << (pd + 16)) / 16_000_000 + 1; // units in one microstep per second
                    assert!((back - v).abs() <= one_pps, "v {v} pd {pd}: {back}");
                }
            }
        }
        assert_eq!(TMC428.position_bits(), 24);
    }

    #[test]
    fn tmc428_accelerations() {
        // 16 MHz² · a / 2^(pd + rd + 29): a = 2047, pd 3, rd 2 is 30 502 676 microsteps/s²; a = 1 at
        // pd 0, rd 0 is 476 837.
        assert_eq!(TMC428.acceleration_to_pps2(2047, 3, 2), 30_502_676);
        assert_eq!(TMC428.acceleration_to_pps2(1, 0, 0), 476_837);
        assert_eq!(TMC428.acceleration_to_pps2(1, 13, 13), 1, "never 0 for a non-zero acceleration");
        assert_eq!(TMC428.acceleration_to_pps2(0, 0, 0), 0);
    }
}
