//! TMCL module models as data: everything that distinguishes one module from another.
//!
//! A model file describes one product in a [`ModelDesc`]: its parameter tables with each parameter's
//! range, access, default and meaning ([`param`]), I/O ports ([`port`]), interrupt vectors and their
//! sources ([`interrupt`]), host interfaces ([`interface`]), the commands it knows (a
//! [`tmcl_wire::CommandSet`]), and where it differs by more than numbers — units, reference-search
//! modes, driver, encoder ([`variant`]). [`ModelSpec::new`] checks the description against the firmware
//! core's capacities ([`capacity`]) and computes its EEPROM layout ([`layout`]) at compile time: a model
//! that does not fit fails to build.
//!
//! ```
//! // A variant of the PD28-1021 with 1024 commands of program memory fits, and its layout shrinks.
//! use tmcl_model::{pd28_1021, ModelDesc, ModelSpec};
//! static SMALLER: ModelSpec = ModelSpec::new(ModelDesc { program_memory: 1024, ..pd28_1021::DESC });
//! assert_eq!(SMALLER.layout().end, 0x400 + 1024 * 8);
//! ```
//!
//! ```compile_fail
//! // 4096 commands of program memory: more than the core holds, so the same does not compile.
//! use tmcl_model::{pd28_1021, ModelDesc, ModelSpec};
//! static TOO_BIG: ModelSpec = ModelSpec::new(ModelDesc { program_memory: 4096, ..pd28_1021::DESC });
//! ```
//!
//! The firmware (`tmcl-core`) and the assembler (`tmcl-asm`) both read these tables; this crate has no
//! dependency but the wire formats and is `no_std`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]

pub mod capacity;
pub mod ethercat;
pub mod interface;
pub mod interrupt;
pub mod layout;
#[cfg(any(test, feature = "std"))]
pub mod names;
pub mod param;
pub mod pd28_1021;
pub mod pd_113;
pub mod port;
#[cfg(any(test, feature = "test-support"))]
pub mod test_three_axes;
pub mod tmcm_1140;
pub mod tmcm_1310;
#[cfg(feature = "multi-axis")]
pub mod tmcm_3110;
#[cfg(feature = "multi-axis")]
pub mod tmcm_6110;
pub mod variant;

pub use ethercat::EtherCatDesc;
pub use interface::{baud_rate, Framing, InterfaceDesc, InterfaceKind, BAUD_RATES};
pub use interrupt::{InterruptDesc, Interrupts, Source, GLOBAL_INTERRUPTS};
pub use layout::Layout;
pub use param::{Access, ParamDesc, ParamError, Range, Role, Setting, Table, Unit};
pub use port::{PortDesc, PortKind};
pub use variant::{
    is_closed_loop, AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes,
};

use capacity::*;
use core::ops::Deref;
use tmcl_wire::{CommandSet, Opcode};

/// Everything that distinguishes one module from another: what a model file writes.
#[derive(Debug)]
pub struct ModelDesc {
    /// The name `--module` takes.
    pub id: &'static str,
    /// The product name.
    pub name: &'static str,
    /// The eight characters of the 136 type 0 reply.
    pub version_string: [u8; 8],
    /// The value of the 136 type 1 reply.
    pub version_binary: i32,
    /// The module number in the EEPROM header (1021 for the PD28-1021): an image of another model is not
    /// taken over.
    pub eeprom_tag: u16,
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
    pub interrupts: Interrupts,
    /// Number of digital inputs.
    pub inputs: u8,
    /// Number of digital outputs.
    pub outputs: u8,
    /// Host interfaces; the first is the primary one.
    pub interfaces: &'static [InterfaceDesc],
    /// What an EtherCAT master sees of the model (identity, process data), if it has an EtherCAT
    /// interface: the SII, the process data and the ESI file are generated from it.
    pub ethercat: Option<&'static EtherCatDesc>,
    /// The commands the model executes (binary interfaces and programs); others answer status 2.
    pub commands: CommandSet,
    /// The commands it takes in ASCII mode.
    pub ascii_commands: CommandSet,
    /// VECT from the host (direct mode) sets an interrupt vector, as in a program: the TMCM-3110/6110's
    /// firmware, whose vectors odemis' TMCL driver sets so before it starts its referencing routine. Else
    /// VECT is a program-only command, status 6 from the host (PD28-1021 manual §3.6.3, §3.7.34).
    pub host_vect: bool,
    /// What command 135 answers.
    pub app_status: AppStatusReply,
    /// The global parameter banks; SGP/GGP/STGP/RSGP/AGP of another bank is status 4.
    pub banks: GlobalBanks,
    /// Units and position width.
    pub kinematics: Kinematics,
    /// The reference-search modes.
    pub reference_modes: ReferenceModes,
    /// The motor driver.
    pub driver: Driver,
    /// The encoder, if the module has one (for a closed-loop module: the encoder it expects by default;
    /// the parameters say which one is attached).
    pub encoder: Option<Encoder>,
    /// Peak coil current in mA at current setting 255, in the driver's low and high current range (the
    /// same twice where the board has one range).
    pub peak_current_ma: [u16; 2],
    /// The password that unlocks the password-protected parameters (written to the bank 0 parameter with
    /// [`Role::Password`]); `None` for a model without protected parameters.
    pub password: Option<i32>,
    /// The manual this model follows.
    pub manual: &'static str,
}

/// A model checked against the core's capacities, with its EEPROM layout. Built only by
/// [`ModelSpec::new`]; reads as its [`ModelDesc`].
#[derive(Debug)]
pub struct ModelSpec {
    desc: ModelDesc,
    layout: Layout,
}

impl Deref for ModelSpec {
    type Target = ModelDesc;
    fn deref(&self) -> &ModelDesc {
        &self.desc
    }
}

/// Why a model does not fit the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitError {
    /// More motors than the core drives.
    Motors,
    /// More axis parameters than the core's table.
    AxisParams,
    /// More bank 0 parameters than the core's table.
    GlobalParams,
    /// More bank 3 parameters than the core's table.
    InterruptParams,
    /// More user variables than the core's table, or more stored than there are.
    UserVariables,
    /// More coordinates than the core's table.
    Coordinates,
    /// More program memory than the core holds, or none.
    ProgramMemory,
    /// More inputs or outputs than the board's bytes carry, or a port on a bit the model does not have.
    Io,
    /// No interface, or more than the core serves.
    Interfaces,
    /// An interrupt's configuration parameter is not in bank 3, or a timer or transition has none.
    InterruptConfig,
    /// A setting the model's features need is missing (see [`ModelSpec::new`]).
    MissingSetting,
    /// The ASCII command set is not a subset of the command set.
    AsciiCommands,
    /// Protected parameters without a password parameter and a password to unlock them.
    Password,
    /// The EtherCAT process-data map names a role the axis table lacks, or has too many inputs.
    EtherCat,
}

impl FitError {
    /// What is wrong, for the compile error.
    pub const fn message(self) -> &'static str {
        match self {
            FitError::Motors => "the model has more motors than the core drives (capacity::MAX_MOTORS)",
            FitError::AxisParams => "too many axis parameters (capacity::MAX_AXIS_PARAMS)",
            FitError::GlobalParams => "too many bank 0 parameters (capacity::MAX_GLOBAL_PARAMS)",
            FitError::InterruptParams => "too many bank 3 parameters (capacity::MAX_INTERRUPT_PARAMS)",
            FitError::UserVariables => "user variables exceed capacity::MAX_USER_VARIABLES or stored > total",
            FitError::Coordinates => "too many coordinates (capacity::MAX_COORDINATES)",
            FitError::ProgramMemory => "program memory is 0 or exceeds capacity::MAX_PROGRAM",
            FitError::Io => "inputs/outputs exceed 8, or a port names a bit the model does not have",
            FitError::Interfaces => "a model has 1..=capacity::MAX_INTERFACES interfaces",
            FitError::InterruptConfig => {
                "an interrupt's configuration parameter is missing from bank 3, or it names a motor the model lacks"
            }
            FitError::MissingSetting => "a feature of the model lacks the setting it needs",
            FitError::AsciiCommands => "the ASCII commands must be a subset of the model's commands",
            FitError::Password => "protected parameters need a Role::Password parameter and a password",
            FitError::EtherCat => "the EtherCAT process data name a role the axis table lacks, or too many inputs",
        }
    }
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

impl ModelSpec {
    /// Checks a model against the core's capacities and computes its layout; in a `static` a model that
    /// does not fit is a compile error (see [`ModelSpec::check`] for what is checked).
    pub const fn new(desc: ModelDesc) -> ModelSpec {
        match ModelSpec::check(&desc) {
            Ok(layout) => ModelSpec { desc, layout },
            Err(e) => panic!("{}", e.message()),
        }
    }

    /// What [`ModelSpec::new`] checks, as a value:
    /// - table sizes, user variables, coordinates, program memory, motors, inputs and outputs against
    ///   [`capacity`];
    /// - every port names an input or output bit the model has;
    /// - 1..=[`MAX_INTERFACES`] interfaces;
    /// - every interrupt's configuration parameter exists in bank 3, timers and transitions have one, and
    ///   every motion source names a motor of the model;
    /// - the settings the model's features need: the ramp's maximum speed and acceleration, the TMC428
    ///   divisors for [`Kinematics::Tmc428`], the three reference-search settings when it has RFS, the
    ///   serial address when an interface filters by address;
    /// - the ASCII commands are commands of the model;
    /// - protected parameters come with a password parameter and a password;
    /// - the EtherCAT process-data map names only roles the axis table has, and fits the slave.
    pub const fn check(d: &ModelDesc) -> Result<Layout, FitError> {
        if d.motors == 0 || d.motors > MAX_MOTORS {
            return Err(FitError::Motors);
        }
        if d.axis.params.len() > MAX_AXIS_PARAMS {
            return Err(FitError::AxisParams);
        }
        if d.global.params.len() > MAX_GLOBAL_PARAMS {
            return Err(FitError::GlobalParams);
        }
        if d.interrupt.params.len() > MAX_INTERRUPT_PARAMS {
            return Err(FitError::InterruptParams);
        }
        if d.user_variables as usize > MAX_USER_VARIABLES || d.stored_user_variables > d.user_variables {
            return Err(FitError::UserVariables);
        }
        if d.coordinates as usize >= MAX_COORDINATES {
            return Err(FitError::Coordinates);
        }
        if d.program_memory == 0 || d.program_memory as usize > MAX_PROGRAM {
            return Err(FitError::ProgramMemory);
        }
        if d.inputs > MAX_INPUTS || d.outputs > MAX_OUTPUTS {
            return Err(FitError::Io);
        }
        let mut i = 0;
        while i < d.ports.len() {
            let ok = match d.ports[i].kind {
                PortKind::DigitalInput(bit) => bit < d.inputs,
                PortKind::Output(bit) => bit < d.outputs,
                // The supply voltage is an analog reading (bank 1), the pull-ups a setting of bank 0.
                PortKind::SupplyVoltage => d.ports[i].bank == 1,
                PortKind::PullUps => d.ports[i].bank == 0,
                _ => true,
            };
            if !ok || d.ports[i].bank > 2 {
                return Err(FitError::Io);
            }
            i += 1;
        }
        if d.interfaces.is_empty() || d.interfaces.len() > MAX_INTERFACES {
            return Err(FitError::Interfaces);
        }
        let mut i = 0;
        while i < d.interrupts.list.len() {
            let irq = &d.interrupts.list[i];
            let needs = matches!(irq.source, Source::Timer(_)) || irq.source.is_level();
            let motor = match irq.source {
                Source::TargetReached(m)
                | Source::Stall(m)
                | Source::Deviation(m)
                | Source::LeftStop(m)
                | Source::RightStop(m) => m,
                Source::Timer(_) | Source::Input(_) => 0,
            };
            if motor >= d.motors {
                return Err(FitError::InterruptConfig);
            }
            match irq.config {
                Some(n) if !d.interrupt.contains(n) => return Err(FitError::InterruptConfig),
                None if needs => return Err(FitError::InterruptConfig),
                _ => {}
            }
            i += 1;
        }
        if !d.axis.has(Setting::MaxPositioningSpeed) || !d.axis.has(Setting::MaxAcceleration) {
            return Err(FitError::MissingSetting);
        }
        if matches!(d.kinematics, Kinematics::Tmc428 { .. })
            && !(d.axis.has(Setting::PulseDivisor) && d.axis.has(Setting::RampDivisor))
        {
            return Err(FitError::MissingSetting);
        }
        if d.commands.contains(Opcode::Rfs)
            && !(d.axis.has(Setting::ReferenceSearchMode)
                && d.axis.has(Setting::ReferenceSearchSpeed)
                && d.axis.has(Setting::ReferenceSwitchSpeed))
        {
            return Err(FitError::MissingSetting);
        }
        if crate::variant::is_closed_loop(&d.axis)
            && !(d.axis.has(Setting::EncoderResolution) && d.axis.has(Setting::MotorFullSteps) && d.encoder.is_some())
        {
            return Err(FitError::MissingSetting);
        }
        let mut i = 0;
        while i < d.interfaces.len() {
            if d.interfaces[i].address_filter && !d.global.has(Setting::SerialAddress) {
                return Err(FitError::MissingSetting);
            }
            i += 1;
        }
        if !d.commands.contains_all(d.ascii_commands) {
            return Err(FitError::AsciiCommands);
        }
        let protected = any_protected(d.axis.params) || any_protected(d.global.params);
        if protected && (d.password.is_none() || d.global.role(Role::Password).is_none()) {
            return Err(FitError::Password);
        }
        if let Some(map) = d.ethercat {
            if ethercat::check(map, &d.axis).is_err() {
                return Err(FitError::EtherCat);
            }
        }
        Ok(Layout::compute(
            d.axis.persistent() * d.motors as usize,
            d.global.persistent(),
            d.stored_user_variables as usize,
            d.coordinates as usize * d.motors as usize,
            d.program_memory as usize,
        ))
    }

    /// The EEPROM layout.
    pub const fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The description.
    pub const fn desc(&self) -> &ModelDesc {
        &self.desc
    }

    /// Looks up a port GIO reads.
    pub fn port(&self, bank: u8, port: u8) -> Option<&'static PortDesc> {
        self.ports.iter().find(|p| p.bank == bank && p.port == port && p.kind.is_readable())
    }

    /// Looks up a port SIO writes (an output, all outputs, the switches' pull-ups).
    pub fn output_port(&self, bank: u8, port: u8) -> Option<&'static PortDesc> {
        self.ports.iter().find(|p| p.bank == bank && p.port == port && p.kind.is_writable())
    }

    /// Whether SIO writes a port of `bank` (bank 2, the outputs, on every model; bank 0 where the model has
    /// the switches' pull-ups there).
    pub fn writes_bank(&self, bank: u8) -> bool {
        self.ports.iter().any(|p| p.bank == bank && p.kind.is_writable())
    }
}

const fn any_protected(params: &[ParamDesc]) -> bool {
    let mut i = 0;
    while i < params.len() {
        if params[i].access.protected {
            return true;
        }
        i += 1;
    }
    false
}

/// Every model this build knows: the multi-axis TMCM-3110 and TMCM-6110 with the `multi-axis` feature
/// (every `std` build), the one-axis models always.
#[cfg(feature = "multi-axis")]
pub static MODELS: &[&ModelSpec] =
    &[&pd28_1021::SPEC, &tmcm_1310::SPEC, &pd_113::SPEC, &tmcm_1140::SPEC, &tmcm_3110::SPEC, &tmcm_6110::SPEC];
/// Every model this build knows: the one-axis models (a build without the `multi-axis` feature drives
/// one motor, see [`capacity::MAX_MOTORS`]).
#[cfg(not(feature = "multi-axis"))]
pub static MODELS: &[&ModelSpec] = &[&pd28_1021::SPEC, &tmcm_1310::SPEC, &pd_113::SPEC, &tmcm_1140::SPEC];

/// Models served on another of their interfaces than the first: the same module, its interfaces in
/// another order (the TMCM-1140, -3110 and -6110 on their RS485 port instead of USB).
#[cfg(feature = "multi-axis")]
static INTERFACE_VARIANTS: &[&ModelSpec] = &[&tmcm_1140::SPEC_RS485, &tmcm_3110::SPEC_RS485, &tmcm_6110::SPEC_RS485];
/// Models served on another of their interfaces than the first (the TMCM-1140 on its RS485 port).
#[cfg(not(feature = "multi-axis"))]
static INTERFACE_VARIANTS: &[&ModelSpec] = &[&tmcm_1140::SPEC_RS485];

/// The model `spec` served on its interface named `interface` (`usb`, `rs485`): `spec` itself when that
/// is its first interface, the variant with that interface first when the model has one, `None` when
/// the model has no such interface to serve.
pub fn on_interface(spec: &'static ModelSpec, interface: &str) -> Option<&'static ModelSpec> {
    if spec.interfaces[0].name.eq_ignore_ascii_case(interface) {
        return Some(spec);
    }
    INTERFACE_VARIANTS.iter().copied().find(|v| v.id == spec.id && v.interfaces[0].name.eq_ignore_ascii_case(interface))
}

/// Finds a model by its `--module` name (case-insensitive).
pub fn by_id(id: &str) -> Option<&'static ModelSpec> {
    MODELS.iter().copied().find(|m| m.id.eq_ignore_ascii_case(id))
}

/// A `--module` name that no model has. Its message names the known ids, so that every tool that takes a
/// model's name (the command line, the runner, the Python package) refuses a wrong one in the same words.
#[cfg(feature = "std")]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownModel {
    /// The name given.
    pub id: std::string::String,
}

#[cfg(feature = "std")]
impl core::fmt::Display for UnknownModel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "unknown module `{}`; known: ", self.id)?;
        for (i, m) in MODELS.iter().enumerate() {
            write!(f, "{}{}", if i == 0 { "" } else { ", " }, m.id)?;
        }
        Ok(())
    }
}

#[cfg(feature = "std")]
impl std::error::Error for UnknownModel {}

/// [`by_id`], or the error that names the known models.
#[cfg(feature = "std")]
pub fn find(id: &str) -> Result<&'static ModelSpec, UnknownModel> {
    by_id(id).ok_or_else(|| UnknownModel { id: id.into() })
}

/// Finds the model whose version string starts like `text`: the module number and the `V` (`1021V` of
/// `1021V142`; command 136 type 0, PD28-1021 TMCL manual §3.7.38).
pub fn by_version(text: &str) -> Option<&'static ModelSpec> {
    by_version_bytes(text.as_bytes())
}

/// [`by_version`] of the raw bytes of a reply (a relay that looks at frames need not decode them).
pub fn by_version_bytes(text: &[u8]) -> Option<&'static ModelSpec> {
    let prefix = text.get(..5)?;
    MODELS.iter().copied().find(|m| m.version_string.get(..5) == Some(prefix))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_id_names_the_known_ones() {
        assert_eq!(find("PD28-1021").map(|m| m.id), Ok("pd28-1021"));
        let e = find("tmcm-9999").unwrap_err();
        let ids: std::vec::Vec<&str> = MODELS.iter().map(|m| m.id).collect();
        assert_eq!(e.to_string(), std::format!("unknown module `tmcm-9999`; known: {}", ids.join(", ")));
    }

    #[test]
    fn models_by_version_string() {
        assert_eq!(by_version("1021V142").map(|m| m.id), Some(pd28_1021::SPEC.id));
        assert_eq!(
            by_version(core::str::from_utf8(&tmcm_1310::SPEC.version_string).unwrap()).map(|m| m.id),
            Some(tmcm_1310::SPEC.id)
        );
        assert!(by_version("9999V100").is_none());
        assert!(by_version("10").is_none(), "too short to name a module");
        assert_eq!(by_version_bytes(b"1021V142\xff").map(|m| m.id), Some(pd28_1021::SPEC.id), "bytes past the prefix");
        assert!(by_version_bytes(b"1021").is_none());
    }

    #[test]
    fn too_much_program_memory_is_refused_with_its_reason() {
        let desc = ModelDesc { program_memory: 4096, ..pd28_1021::DESC };
        assert_eq!(ModelSpec::check(&desc), Err(FitError::ProgramMemory));
    }

    #[test]
    fn each_capacity_is_checked() {
        let d = || pd28_1021::DESC;
        assert_eq!(ModelSpec::check(&ModelDesc { motors: MAX_MOTORS + 1, ..d() }), Err(FitError::Motors));
        assert_eq!(ModelSpec::check(&ModelDesc { motors: 0, ..d() }), Err(FitError::Motors));
        assert_eq!(ModelSpec::check(&ModelDesc { coordinates: 21, ..d() }), Err(FitError::Coordinates));
        assert_eq!(ModelSpec::check(&ModelDesc { outputs: 1, ..d() }), Err(FitError::Io), "OUT1 has no bit");
        assert_eq!(ModelSpec::check(&ModelDesc { interfaces: &[], ..d() }), Err(FitError::Interfaces));
        assert_eq!(ModelSpec::check(&ModelDesc { stored_user_variables: 257, ..d() }), Err(FitError::UserVariables));
        assert_eq!(ModelSpec::check(&ModelDesc { interrupt: Table::EMPTY, ..d() }), Err(FitError::InterruptConfig));
        assert_eq!(ModelSpec::check(&ModelDesc { global: Table::EMPTY, ..d() }), Err(FitError::MissingSetting));
        assert!(ModelSpec::check(&d()).is_ok());
        // The TMCM-1310's process data name the closed loop's roles (gamma, measured velocity), which the
        // PD28-1021's table does not have.
        let map = Some(&tmcm_1310::ETHERCAT);
        assert_eq!(ModelSpec::check(&ModelDesc { ethercat: map, ..d() }), Err(FitError::EtherCat));
        assert!(ModelSpec::check(&ModelDesc { ethercat: map, ..tmcm_1310::DESC }).is_ok());
    }

    /// The units follow the meaning: every speed the firmware reads is in pps, every acceleration in pps/s,
    /// every position in microsteps (the manuals' "Range \[Units\]" columns), on every model.
    #[test]
    fn units_follow_the_meaning() {
        for model in MODELS {
            for p in model.axis.params {
                let (pps, pps2) = match model.kinematics {
                    Kinematics::Pps => (Unit::Pps, Unit::PpsPerSecond),
                    Kinematics::Tmc428 { .. } => (Unit::Tmc428Velocity, Unit::Tmc428Acceleration),
                };
                let expected = match (p.role, p.setting) {
                    (Role::TargetPosition | Role::ActualPosition, _) => Some(Unit::Microsteps),
                    (Role::TargetSpeed | Role::ActualSpeed, _) => Some(pps),
                    (_, Some(Setting::MaxPositioningSpeed | Setting::MinimumSpeed)) => Some(pps),
                    (_, Some(Setting::ReferenceSearchSpeed | Setting::ReferenceSwitchSpeed)) => Some(pps),
                    (_, Some(Setting::MaxAcceleration)) => Some(pps2),
                    (_, Some(Setting::RunCurrent | Setting::StandbyCurrent)) => Some(Unit::CurrentOf255),
                    _ => None,
                };
                if let Some(unit) = expected {
                    assert_eq!(p.unit, unit, "{} AP {} {}", model.id, p.number, p.name);
                }
            }
        }
    }

    #[test]
    fn models_are_found_by_id() {
        assert_eq!(by_id("PD28-1021").map(|m| m.name), Some("PD28-1021"));
        assert!(by_id("tmcm-9999").is_none());
    }

    #[test]
    fn a_model_on_another_interface() {
        let usb = by_id("tmcm-1140").unwrap();
        assert!(core::ptr::eq(on_interface(usb, "usb").unwrap(), usb));
        let rs485 = on_interface(usb, "RS485").unwrap();
        assert_eq!((rs485.id, rs485.interfaces[0].name), ("tmcm-1140", "rs485"));
        assert!(on_interface(usb, "can").is_none(), "CAN is not simulated");
        assert!(on_interface(by_id("pd28-1021").unwrap(), "usb").is_none());
        assert!(on_interface(by_id("pd28-1021").unwrap(), "rs485").is_some());
    }
}
