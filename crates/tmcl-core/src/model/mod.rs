//! Product models as data (STYLE.md §3.9): one static [`ModelSpec`] per module.

pub mod pd28_1021;

use crate::param::Table;

/// What a GIO/SIO port is (manual §3.7.14, §3.7.15).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortKind {
    /// A digital input; the field is its bit in the board's input byte.
    DigitalInput(u8),
    /// All digital inputs as a bit vector (GIO 255, 0).
    AllInputs,
    /// Whether the sensOstep encoder is near its absolute zero (GIO 11, 0).
    EncoderNearZero,
    /// A 12-bit analog input; the field is the ADC channel.
    Analog(u8),
    /// The module temperature.
    Temperature,
    /// A digital output (SIO and GIO on bank 2); the field is its bit.
    Output(u8),
    /// All outputs as a bit vector (SIO 255, 2).
    AllOutputs,
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

/// One interrupt vector (manual §3.6.6 Table 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterruptDesc {
    /// The interrupt number (EI/DI/VECT type byte; priority: lower first).
    pub number: u8,
    /// The manual's name.
    pub name: &'static str,
    /// The assembler symbol (`Interrupts.inc`).
    pub symbol: &'static str,
}

/// The global interrupt switch of EI/DI (§3.7.32).
pub const GLOBAL_INTERRUPTS: u8 = 255;

/// Everything that distinguishes one module from another.
#[derive(Debug)]
pub struct ModelSpec {
    /// The name `--module` takes.
    pub id: &'static str,
    /// The product name.
    pub name: &'static str,
    /// The eight characters of the 136 type 0 reply.
    pub version_string: [u8; 8],
    /// The value of the 136 type 1 reply.
    pub version_binary: i32,
    /// Number of motors.
    pub motors: u8,
    /// Axis parameters.
    pub axis: Table,
    /// Global parameters, bank 0.
    pub global: Table,
    /// Interrupt configuration, bank 3.
    pub interrupt: Table,
    /// Number of user variables in bank 2.
    pub user_variables: u16,
    /// How many of them (from 0) STGP can store.
    pub stored_user_variables: u16,
    /// Coordinates per axis (1..=n; coordinate 0 is extra and RAM only).
    pub coordinates: u8,
    /// Program memory, in commands.
    pub program_memory: u16,
    /// I/O ports.
    pub ports: &'static [PortDesc],
    /// Interrupt vectors.
    pub interrupts: &'static [InterruptDesc],
    /// Number of digital outputs.
    pub outputs: u8,
    /// The manual this model follows.
    pub manual: &'static str,
}

impl ModelSpec {
    /// Looks up a port.
    pub fn port(&self, bank: u8, port: u8) -> Option<&'static PortDesc> {
        self.ports.iter().find(|p| p.bank == bank && p.port == port)
    }
}

/// Every model this build knows.
pub static MODELS: &[&ModelSpec] = &[&pd28_1021::SPEC];

/// Finds a model by its `--module` name (case-insensitive).
pub fn by_id(id: &str) -> Option<&'static ModelSpec> {
    MODELS.iter().copied().find(|m| m.id.eq_ignore_ascii_case(id))
}
