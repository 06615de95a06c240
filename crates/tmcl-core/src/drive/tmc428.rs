//! SAC (command 29, PDx-113 manual §5.4.3 "Access to external SPI device"): the SPI pass-through to an
//! emulated TMC428/429 motion controller.
//!
//! The manual names the command and is cut off before its section. TMCL's operands are `SAC <bus
//! number>, <number of bytes>, <send data>` ([`tmcl_wire::Command::Sac`]); our reading for this module:
//! bus 0 is the motion controller, whose datagrams are always 32 bits (TMC428 datasheet), so the number
//! of bytes is 4 and the value the datagram ([`tmcl_wire::tmc428`]); the reply value is the 32-bit
//! answer, status bits and data. Another bus is status 3 (wrong type: the TMC249 driver is reached only
//! through the motion controller's cover datagram), another number of bytes status 4.
//!
//! # The register file (TMC428 datasheet register map; TMC429 datasheet §8–§10)
//!
//! Motor 0 (SMDA 0) is the motor the firmware drives, so its registers are the firmware's state seen in
//! TMC428 units, and writing them is writing the axis parameter behind each (with that parameter's range
//! and status): IDX 0 x_target (AP 0; in velocity mode the target is only stored, as on the chip),
//! 1 x_actual (AP 1), 2 v_min (AP 130), 3 v_max (AP 4), 4 v_target (AP 2), 5 v_actual (AP 3; writing 0
//! stops at once — the firmware's hard stop —, another value is not taken over, the ramp owns it),
//! 6 a_max (AP 5), 7 a_actual (AP 5 while the speed changes, else 0; the sign is not modelled), 10
//! ref_conf and ramp mode (bits 1..0 = AP 138; bit 8 DISABLE_STOP_L = AP 13, bit 9 DISABLE_STOP_R =
//! AP 12; the other bits stored), 12 pulse_div (bits 15..12, AP 154), ramp_div (bits 11..8, AP 153) and
//! usrs (bits 2..0, AP 140), 9 pmul/pdiv (see [`pmul_pdiv`]: what the firmware computes from a_max and
//! the divisors, or what a host wrote since they last changed). The rest of motor 0 (8 a_threshold, 11
//! interrupt mask and flags, 13 dx_ref_tolerance, 14 x_latched) and every register of motors 1 and 2,
//! which have no motor on this board, are stored as written (24 bits) and read back; nothing acts on
//! them. IDX 15 reads 0.
//!
//! The common registers (SMDA 3): JDX 0/1 (datagram low/high word) read 0, the answer of a TMC249 with
//! no error bit set (the simulated driver has no fault); 2, 3, 4, 5, 6, 15 (cover position/length, cover
//! datagram, interface configuration, position compare and its interrupt, the stepper motor global
//! parameters) are stored; a cover datagram is sent at once, so CDGW stays 0; 8 (power down) does
//! nothing; 9 reads the TMC429's type/version 0x429101; 14 reads the reference switches (bit 0 the left,
//! bit 1 the right switch of motor 0); the others read 0. The RAM (RRS = 1, 64 addresses of two 6-bit
//! entries, the driver chain and quarter sine wave tables) is stored and read back.
//!
//! Status bits of every answer: xEQt1 = x_actual equals x_target of motor 0, xEQt2/3 likewise for the
//! stored registers of motors 1 and 2, RS1 = the left stop switch (the reference input of motor 0);
//! INT, CDGW, RS2, RS3 stay 0 (no interrupts on this module, §5.4).

/// The TMC429's type and version (TMC429 datasheet, JDX 9).
pub const TYPE_VERSION: u32 = 0x42_9101;

/// The registers no firmware state stands behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tmc428Regs {
    pub(crate) motors: [[u32; 16]; 3],
    pub(crate) common: [u32; 16],
    pub(crate) ram: [u16; 64],
    /// a_max, pulse_div and ramp_div when a host last wrote motor 0's pmul/pdiv: while they are the same
    /// the written value stands, once one changes the firmware's own calculation does again.
    pub(crate) pmul_written_at: Option<(u32, u32, u32)>,
}

impl Default for Tmc428Regs {
    fn default() -> Self {
        // Power-up: every register 0 (the TMC428 datasheet: x_target, x_actual, v_min, v_max, a_max 0).
        Tmc428Regs { motors: [[0; 16]; 3], common: [0; 16], ram: [0; 64], pmul_written_at: None }
    }
}

/// Register 9 of a motor, pmul (bits 15..8, 128..255) and pdiv (bits 3..0), for `a_max` and the pulse
/// and ramp divisors: the pair the TMC428 datasheet's calculation gives (its section on pmul and pdiv,
/// the same in the TMC429 datasheet §8.1.7 and §8.1.10), which a firmware for the chip writes whenever
/// a_max or a divisor changes. With `p = a_max / (128 · 2^(ramp_div − pulse_div))` reduced by 1 %
/// (`p_reduction` 0.01, the datasheet's example value) it takes, of the `pdiv` in 0..=13 for which
/// `pmul = ⌊p_reduced · 8 · 2^pdiv⌋ − 128` lies in 0..=127, the last one, and `pm = pmul + 128`.
/// Computed in integers, `⌊a_max · 99 · 2^(pdiv + pulse_div) / (1600 · 2^ramp_div)⌋`, so the
/// result does not depend on floating-point rounding. No such pair (a_max 0, or a_max too small for the
/// divisors) reads 0.
pub fn pmul_pdiv(a_max: u32, pulse_div: u32, ramp_div: u32) -> u32 {
    let (a, pulse, ramp) = (u64::from(a_max & MASK11), pulse_div.min(15), ramp_div.min(15));
    let mut found = 0;
    for pdiv in 0..=13u32 {
        let scaled = (a * 99) << (pdiv + pulse);
        let x = scaled / (1600u64 << ramp);
        if (128..=255).contains(&x) {
            found = ((x as u32) << 8) | pdiv;
        }
    }
    found
}

pub(crate) const MASK24: u32 = 0x00FF_FFFF;
pub(crate) const MASK11: u32 = 0x7FF;
pub(crate) const MASK12: u32 = 0xFFF;

#[cfg(test)]
mod tests {
    use super::pmul_pdiv;

    #[test]
    fn pmul_and_pdiv_as_the_datasheet_computes_them() {
        // a_max 1000, pulse_div 3, ramp_div 7: p = 1000 / (128 · 16) = 0.488, reduced 0.483; 0.483 · 8 ·
        // 2^6 = 247.5, so pmul 247, pdiv 6 (2^7 gives 495, out of range).
        assert_eq!(pmul_pdiv(1000, 3, 7), (247 << 8) | 6);
        // a_max 2047, pulse_div 0, ramp_div 0: p = 15.99, reduced 15.83; · 8 = 126.6 (too small), · 16 =
        // 253.3: pmul 253, pdiv 1.
        assert_eq!(pmul_pdiv(2047, 0, 0), (253 << 8) | 1);
        // a_max 1 at pulse_div 0, ramp_div 13: p = 1 / (128 · 8192); even · 8 · 2^13 it is 0.06: no pair.
        assert_eq!(pmul_pdiv(1, 0, 13), 0);
        // a_max 500 at pulse_div 3, ramp_div 7: p_reduced 0.2417; · 8 · 2^7 = 247.5: pmul 247, pdiv 7.
        assert_eq!(pmul_pdiv(500, 3, 7), (247 << 8) | 7);
        assert_eq!(pmul_pdiv(0, 3, 7), 0, "a_max 0: no pair");
        // pm always has its top bit set (128..=255), pdiv in 0..=13.
        for a in [1, 7, 100, 1000, 2047] {
            for pulse in 0..=13 {
                for ramp in 0..=13 {
                    let v = pmul_pdiv(a, pulse, ramp);
                    assert!(v == 0 || (v >> 15 == 1 && v & 0xF <= 13 && v >> 16 == 0), "{a} {pulse} {ramp}: {v:#x}");
                }
            }
        }
    }
}
