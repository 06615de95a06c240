//! I/O ports as data: what each GIO/SIO port number of a bank is (PD28-1021 manual §3.7.14 SIO and
//! §3.7.15 GIO, with their port tables).

/// What a GIO/SIO port is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortKind {
    /// A digital input; the field is its bit in the board's input byte.
    DigitalInput(u8),
    /// All digital inputs as a bit vector (GIO 255, 0).
    AllInputs,
    /// Whether the encoder is near its absolute zero (PD28-1021 GIO 11, 0).
    EncoderNearZero,
    /// A 12-bit analog input; the field is the ADC channel.
    Analog(u8),
    /// A 10-bit analog input, 0..1023 (PDx-113 manual §5.7.15.2); the field is the ADC channel. The
    /// board's inputs are 12-bit: the value is the board's divided by 4.
    Analog10(u8),
    /// The module temperature.
    Temperature,
    /// A digital output (SIO and GIO on bank 2); the field is its bit.
    Output(u8),
    /// All outputs as a bit vector (SIO 255, 2).
    AllOutputs,
    /// The supply voltage in 0.1 V (GIO 8, 1 on the TMCM-3110/6110: odemis' TMCL driver reads it before
    /// it moves anything, "the IDE uses this feature too").
    SupplyVoltage,
    /// The pull-up resistors of the reference switch inputs, set with SIO (SIO 0, 0 on the TMCM-3110/6110,
    /// as odemis' TMCL driver sets them): the value's low bits switch them (0..=3). Written only: GIO of the
    /// same port reads the input there.
    PullUps,
}

impl PortKind {
    /// Whether GIO reads the port.
    pub const fn is_readable(self) -> bool {
        !matches!(self, PortKind::PullUps)
    }

    /// Whether SIO writes the port.
    pub const fn is_writable(self) -> bool {
        matches!(self, PortKind::Output(_) | PortKind::AllOutputs | PortKind::PullUps)
    }
}

/// One I/O port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortDesc {
    /// GIO/SIO bank: 0 digital inputs, 1 analog inputs, 2 outputs.
    pub bank: u8,
    /// Port number (the type byte).
    pub port: u8,
    /// What it is.
    pub kind: PortKind,
    /// A name for humans.
    pub name: &'static str,
}
