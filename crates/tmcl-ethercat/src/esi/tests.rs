//! The ESI file read back (roxmltree) and compared, element by element, with the SII image the slave
//! serves: identity, name and group, FMMUs, SyncManagers, PDOs and their entries, mailbox protocols,
//! configuration data and bootstrap mailbox.

use super::*;
use crate::slave::Slave;
use crate::wire::sii::{self, categories, string, CategoryType, General, Pdo, PdoEntry, SyncManager};
use roxmltree::{Document, Node};
use tmcl_core::model::tmcm_1310::{ETHERCAT, SPEC};

fn esi() -> String {
    let mut s = String::new();
    write(&SPEC, &ETHERCAT, &mut s).unwrap();
    s
}

fn hex(text: &str) -> u32 {
    u32::from_str_radix(text.trim().trim_start_matches("#x"), 16).unwrap()
}

fn child<'a>(n: Node<'a, 'a>, name: &str) -> Node<'a, 'a> {
    n.children().find(|c| c.has_tag_name(name)).unwrap_or_else(|| panic!("no <{name}> in <{}>", n.tag_name().name()))
}

fn text<'a>(n: Node<'a, 'a>, name: &str) -> &'a str {
    child(n, name).text().unwrap_or("")
}

fn category(image: &[u8], kind: CategoryType) -> Vec<u8> {
    categories(image).find(|c| c.category_type() == kind).map(|c| c.data().to_vec()).unwrap()
}

#[test]
fn the_esi_says_what_the_sii_the_slave_serves_says() {
    let xml = esi();
    let doc = Document::parse(&xml).expect("well-formed XML");
    let slave = Slave::new(&SPEC).unwrap();
    let sii = slave.eeprom();
    let image = sii.image();
    let strings = category(image, CategoryType::Strings);
    let general = General::parse(&category(image, CategoryType::General)).unwrap();
    let s = |i: u8| String::from_utf8(string(&strings, i).unwrap().to_vec()).unwrap();

    let root = doc.root_element();
    assert_eq!(hex(text(child(root, "Vendor"), "Id")), sii.word32(word::VENDOR_ID));
    let device = child(child(child(root, "Descriptions"), "Devices"), "Device");
    let kind = child(device, "Type");
    assert_eq!(hex(kind.attribute("ProductCode").unwrap()), sii.word32(word::PRODUCT_CODE));
    assert_eq!(hex(kind.attribute("RevisionNo").unwrap()), sii.word32(word::REVISION));
    assert_eq!(text(device, "Name"), s(general.name));
    assert_eq!(text(device, "GroupType"), s(general.group));

    let fmmus: Vec<&str> = device.children().filter(|c| c.has_tag_name("Fmmu")).map(|c| c.text().unwrap()).collect();
    let usage: Vec<&str> = category(image, CategoryType::Fmmu)
        .iter()
        .filter_map(|u| match *u {
            sii::fmmu_usage::OUTPUTS => Some("Outputs"),
            sii::fmmu_usage::INPUTS => Some("Inputs"),
            sii::fmmu_usage::SM_STATUS => Some("MBoxState"),
            _ => None,
        })
        .collect();
    assert_eq!(fmmus, usage);

    let sms: Vec<Node> = device.children().filter(|c| c.has_tag_name("Sm")).collect();
    let syncm = category(image, CategoryType::SyncManager);
    assert_eq!(sms.len(), syncm.len() / SyncManager::LEN);
    for (sm, raw) in sms.iter().zip(syncm.chunks_exact(SyncManager::LEN)) {
        let want = SyncManager::parse(raw).unwrap();
        assert_eq!(hex(sm.attribute("StartAddress").unwrap()), u32::from(want.start));
        assert_eq!(sm.attribute("DefaultSize").unwrap().parse::<u16>().unwrap(), want.length);
        assert_eq!(hex(sm.attribute("ControlByte").unwrap()), u32::from(want.control));
        assert_eq!(sm.attribute("Enable").unwrap(), want.enable.to_string());
        let usage = ["", "MBoxOut", "MBoxIn", "Outputs", "Inputs"][usize::from(want.sm_type)];
        assert_eq!(sm.text().unwrap(), usage);
    }

    for (element, kind) in [("RxPdo", CategoryType::RxPdo), ("TxPdo", CategoryType::TxPdo)] {
        let pdo = child(device, element);
        let raw = category(image, kind);
        let head = Pdo::parse(&raw).unwrap();
        assert_eq!(hex(text(pdo, "Index")), u32::from(head.index));
        assert_eq!(pdo.attribute("Sm").unwrap(), head.sync_manager.to_string());
        assert_eq!(text(pdo, "Name"), s(head.name));
        let entries: Vec<Node> = pdo.children().filter(|c| c.has_tag_name("Entry")).collect();
        assert_eq!(entries.len(), usize::from(head.entries));
        for (e, raw) in entries.iter().zip(raw[Pdo::LEN..].chunks_exact(PdoEntry::LEN)) {
            let want = PdoEntry::parse(raw).unwrap();
            assert_eq!(hex(text(*e, "Index")), u32::from(want.index));
            assert_eq!(text(*e, "SubIndex").parse::<u8>().unwrap(), want.subindex);
            assert_eq!(text(*e, "BitLen").parse::<u8>().unwrap(), want.bit_length);
            assert_eq!(text(*e, "Name"), s(want.name));
            let code = match text(*e, "DataType") {
                "DINT" => DataType::Integer32.code(),
                "UDINT" => DataType::Unsigned32.code(),
                other => panic!("type {other}"),
            };
            assert_eq!(code, want.data_type);
        }
    }

    let mailbox = child(device, "Mailbox");
    let protocols: u16 = mailbox
        .children()
        .filter(|c| c.is_element())
        .map(|c| match c.tag_name().name() {
            "AoE" => sii::protocol::AOE,
            "EoE" => sii::protocol::EOE,
            "CoE" => sii::protocol::COE,
            "FoE" => sii::protocol::FOE,
            "SoE" => sii::protocol::SOE,
            "VoE" => sii::protocol::VOE,
            other => panic!("protocol {other}"),
        })
        .sum();
    assert_eq!(protocols, sii.word(word::MAILBOX_PROTOCOL));

    let eeprom = child(device, "Eeprom");
    assert_eq!(text(eeprom, "ByteSize").parse::<usize>().unwrap(), image.len());
    let bytes =
        |t: &str| (0..t.len()).step_by(2).map(|i| u8::from_str_radix(&t[i..i + 2], 16).unwrap()).collect::<Vec<u8>>();
    assert_eq!(bytes(text(eeprom, "ConfigData")), image[..14]);
    assert_eq!(bytes(text(eeprom, "BootStrap")), image[2 * 0x14..2 * 0x18]);
}

#[test]
fn the_esi_begins_as_etg_2000_files_do() {
    let xml = esi();
    assert!(xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"));
    assert!(xml.contains("<Name>TRINAMIC Motion Control GmbH &amp; Co. KG</Name>"));
    assert!(xml.contains(r##"<Type ProductCode="#x0000051E" RevisionNo="#x0001000E">TMCM-1310</Type>"##));
    assert!(xml.contains(r##"<Sm DefaultSize="268" StartAddress="#x1000" ControlByte="#x26" Enable="1">MBoxOut</Sm>"##));
}
