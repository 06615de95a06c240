//! Host interfaces as data: the ports a module talks on and how each frames and addresses commands.
//!
//! The PD28-1021 has one RS485 port (manual §3.1); the TMCM-1310 has USB (its manual chapter 4) and an
//! EtherCAT mailbox that carries TMCL without address and checksum (its manual chapter 3). The firmware
//! keeps a framer, an outbox and an ASCII line per interface and answers on the interface that asked.

/// The baud rates of the serial interfaces, indexed by the value of GP 65 (PD28-1021 manual §5.1,
/// Table 17: 0 = 9600 … 8 = 230400; 8 data bits, no parity, one stop bit). A new value is in force after
/// the next restart.
pub const BAUD_RATES: [u32; 9] = [9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200, 230400];

/// The baud rate of GP 65 value `index`; an index past Table 17 falls back to 9600, the factory setting.
pub const fn baud_rate(index: u8) -> u32 {
    if (index as usize) < BAUD_RATES.len() {
        BAUD_RATES[index as usize]
    } else {
        BAUD_RATES[0]
    }
}

/// How an interface frames TMCL.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// 9-byte frames: address, command, type, motor/bank, value (4), checksum (PD28-1021 manual §3.1).
    Binary,
    /// 8-byte mailbox messages without a checksum, each one whole (TMCM-1310 manual §3.5–3.6): requests
    /// are address, command, type, motor/bank, value (4, MSB first); replies are reply address, module
    /// address, status, command, value (4). There is no byte stream, so no framer and no ASCII mode.
    Mailbox,
}

/// What kind of link an interface is (for names, logs and the board profile).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InterfaceKind {
    /// RS485, a multi-drop bus.
    Rs485,
    /// RS232, point to point.
    Rs232,
    /// USB (a virtual COM port).
    Usb,
    /// The EtherCAT mailbox.
    EtherCatMailbox,
}

/// One host interface of a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterfaceDesc {
    /// A name for humans and for `--interface`.
    pub name: &'static str,
    /// The link.
    pub kind: InterfaceKind,
    /// How TMCL is framed on it.
    pub framing: Framing,
    /// Only frames for the module address (GP 66) or the secondary address (GP 87) are answered (a
    /// bus); otherwise every frame is, whatever its address byte.
    pub address_filter: bool,
    /// ASCII mode (command 139) is available on it.
    pub ascii: bool,
    /// The telegram pause time (GP 75) delays its replies.
    pub telegram_pause: bool,
    /// Reply suppression (GP 255) applies to it.
    pub suppressible: bool,
}

impl InterfaceDesc {
    /// An RS485 bus port as the PD28-1021's (manual §3.1, §3.4, §5.1 GP 66, 75, 87, 255).
    pub const RS485: InterfaceDesc = InterfaceDesc {
        name: "rs485",
        kind: InterfaceKind::Rs485,
        framing: Framing::Binary,
        address_filter: true,
        ascii: true,
        telegram_pause: true,
        suppressible: true,
    };

    /// The EtherCAT mailbox as the TMCM-1310's (its manual §3.5–3.6): whole 8-byte messages, no address
    /// filter, no ASCII mode, no telegram pause, no reply suppression.
    pub const ETHERCAT_MAILBOX: InterfaceDesc = InterfaceDesc {
        name: "ethercat-mailbox",
        kind: InterfaceKind::EtherCatMailbox,
        framing: Framing::Mailbox,
        address_filter: false,
        ascii: false,
        telegram_pause: false,
        suppressible: false,
    };
}
