//! Client tests against [`MockTransport`]: exact request bytes, reply checks, special replies.

use super::*;
use crate::MockTransport;
use tmcl_wire::command::EventMode;

fn reply(status: Status, opcode: u8, value: i32) -> [u8; FRAME_LEN] {
    Reply { host: 2, module: 1, status, opcode, value }.to_bytes()
}

fn reply_from(module: u8, status: Status, opcode: u8, value: i32) -> [u8; FRAME_LEN] {
    Reply { host: 2, module, status, opcode, value }.to_bytes()
}

fn client_answering(frames: &[[u8; FRAME_LEN]]) -> Client<MockTransport> {
    let mut transport = MockTransport::new();
    for frame in frames {
        transport.push_input(frame);
    }
    Client::new(transport)
}

/// PD28-1021 manual §3.1.1: `ROR 0, 500` is `01 01 00 00 00 00 01 F4 F7`.
#[test]
fn request_bytes_match_manual_ror_example() {
    let mut client = client_answering(&[reply(Status::Ok, 1, 500)]);
    client.rotate(0, 500).unwrap();
    assert_eq!(client.transport_mut().sent, [0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0xF4, 0xF7]);
}

/// PD28-1021 manual §3.7.15: `GIO 0, 1` answered with value 302, reply `02 01 64 0F 00 00 01 2E A5`.
#[test]
fn get_io_manual_example() {
    let mut client = client_answering(&[[0x02, 0x01, 0x64, 0x0F, 0x00, 0x00, 0x01, 0x2E, 0xA5]]);
    assert_eq!(client.get_io(0, 1).unwrap(), 302);
    assert_eq!(client.transport_mut().sent, [0x01, 0x0F, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x11]);
}

#[test]
fn wrappers_encode_parameters_and_negative_values() {
    let mut client = client_answering(&[
        reply(Status::Ok, 5, -5000),
        reply(Status::Ok, 6, -5000),
        reply(Status::Ok, 9, 3),
        reply(Status::Ok, 10, 3),
        reply(Status::Ok, 7, 0),
        reply(Status::Ok, 11, 0),
    ]);
    client.set_axis_parameter(1, 0, -5000).unwrap();
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), -5000);
    client.set_global_parameter(77, 0, 3).unwrap();
    assert_eq!(client.get_global_parameter(77, 0).unwrap(), 3);
    client.store_axis_parameter(4, 0).unwrap();
    client.store_global_parameter(66, 0).unwrap();
    let sent = client.transport_mut().take_sent();
    let frames: Vec<&[u8]> = sent.chunks(FRAME_LEN).collect();
    // SAP 1, 0, -5000: value FF FF EC 78, checksum 873 & 0xFF = 0x69.
    assert_eq!(frames[0], [0x01, 0x05, 0x01, 0x00, 0xFF, 0xFF, 0xEC, 0x78, 0x69]);
    assert_eq!(frames[1], [0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08]);
    assert_eq!(frames[2], [0x01, 0x09, 0x4D, 0x00, 0x00, 0x00, 0x00, 0x03, 0x5A]);
    assert_eq!(frames[3], [0x01, 0x0A, 0x4D, 0x00, 0x00, 0x00, 0x00, 0x00, 0x58]);
    assert_eq!(frames[4], [0x01, 0x07, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0C]);
    assert_eq!(frames[5], [0x01, 0x0B, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4E]);
}

#[test]
fn module_address_goes_in_byte_0() {
    let mut client = client_answering(&[reply_from(5, Status::Ok, 3, 0)]).with_module_address(5);
    client.stop(0).unwrap();
    assert_eq!(client.transport_mut().sent, [0x05, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08]);
}

#[test]
fn checksum_error_keeps_the_frame_and_drains() {
    let mut bad = reply(Status::Ok, 6, 302);
    bad[8] ^= 0xFF;
    let mut client = client_answering(&[bad]);
    let err = client.get_axis_parameter(1, 0).unwrap_err();
    match &err {
        HostError::Checksum { expected, found, frame } => {
            assert_eq!(*expected, bad[8] ^ 0xFF);
            assert_eq!(*found, bad[8]);
            assert_eq!(*frame, bad);
        }
        other => panic!("expected a checksum error, got {other:?}"),
    }
    assert!(err.is_bad_reply() && !err.is_status_error());
    // Late bytes on the line are drained before the next request, not taken for its answer.
    client.transport_mut().push_input(&[0xAA]);
    client.transport_mut().push_input(&reply(Status::Ok, 6, 7));
    client.transport_mut().answer_next(&reply(Status::Ok, 6, 8));
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 8);
    assert_eq!(client.take_skipped(), [Reply { host: 2, module: 1, status: Status::Ok, opcode: 6, value: 7 }]);
}

#[test]
fn error_status_keeps_the_reply() {
    let mut client = client_answering(&[reply(Status::InvalidValue, 5, 123)]);
    let err = client.set_axis_parameter(4, 0, 1_000_000).unwrap_err();
    match &err {
        HostError::Status { status, reply } => {
            assert_eq!(*status, Status::InvalidValue);
            assert_eq!((reply.opcode, reply.value, reply.module), (5, 123, 1));
        }
        other => panic!("expected a status error, got {other:?}"),
    }
    assert_eq!(err.to_string(), "module answered status 4 (invalid value)");
    assert!(err.is_reply_error());
}

#[test]
fn success_statuses_from_100_up() {
    let mut client = client_answering(&[
        reply(Status::Loaded, 4, 0),
        reply(Status::Unknown(200), 4, 0),
        reply(Status::Unknown(99), 4, 0),
    ]);
    assert_eq!(client.request(Instruction::new(Opcode::Mvp, 0, 0, 0)).unwrap().status, Status::Loaded);
    assert!(client.request(Instruction::new(Opcode::Mvp, 0, 0, 0)).is_ok());
    assert!(matches!(
        client.request(Instruction::new(Opcode::Mvp, 0, 0, 0)),
        Err(HostError::Status { status: Status::Unknown(99), .. })
    ));
}

#[test]
fn timeout_reports_what_arrived() {
    let mut client = client_answering(&[]).with_timeout(Duration::from_millis(250));
    client.transport_mut().push_input(&[0x02, 0x01, 0x64]);
    let err = client.get_axis_parameter(1, 0).unwrap_err();
    assert!(matches!(err, HostError::Timeout { received: 3, waited } if waited == Duration::from_millis(250)));
    assert!(!err.is_reply_error() && err.is_no_reply());
    // The half frame and what follows it are gone before the next request goes out.
    client.transport_mut().push_input(&[0x55]);
    client.request_no_reply(Command::Mst { motor: 0 }.encode()).unwrap();
    assert!(client.transport_mut().input.is_empty());
    assert_eq!(client.transport_mut().sent.len(), 2 * FRAME_LEN);
}

/// Command 136 type 0: host address and `1021V142`, no checksum (the manual gives no layout; pytrinamic's `get_version_string` and TMC-EvalSystem `tx()` use this one).
#[test]
fn version_string_raw_reply() {
    let mut raw = [0u8; FRAME_LEN];
    raw[0] = 2;
    raw[1..].copy_from_slice(b"1021V142");
    let mut client = client_answering(&[raw]);
    assert_eq!(client.version_string().unwrap(), "1021V142");
    assert_eq!(client.transport_mut().sent, [0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]);
}

#[test]
fn version_string_error_reply_and_garbage() {
    let mut client = client_answering(&[reply(Status::InvalidCommand, 136, 0)]);
    assert!(matches!(client.version_string(), Err(HostError::Status { status: Status::InvalidCommand, .. })));
    let garbage = [2, 0xFF, 0, 0, 0, 0, 0, 0, 0];
    let mut client = client_answering(&[garbage]);
    assert!(matches!(client.version_string(), Err(HostError::BadVersionString { frame }) if frame == garbage));
}

#[test]
fn version_binary_decoded() {
    let mut client = client_answering(&[reply(Status::Ok, 136, 0x0A15_012A)]);
    let version = client.firmware_version().unwrap();
    assert_eq!(version, FirmwareVersion { module: Some(1021), major: 1, minor: 42 });
    assert_eq!(client.transport_mut().sent, [0x01, 0x88, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8A]);
}

/// §3.7.37: the 138 event may arrive while another request waits; it is set aside for `wait_event`.
#[test]
fn target_reached_event_set_aside() {
    let event = reply(Status::TargetReached, 138, 1);
    let mut client =
        client_answering(&[reply(Status::Ok, 138, 1), reply(Status::Ok, 4, 1000), event, reply(Status::Ok, 6, 1000)]);
    let mode = Command::RequestTargetReachedEvent { mode: EventMode::Next, mask: 1 };
    assert_eq!(client.request(mode.encode()).unwrap().status, Status::Ok);
    client.move_to(0, 1000).unwrap();
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 1000);
    let got = client.wait_event(Duration::from_secs(1)).unwrap();
    assert_eq!((got.status, got.opcode, got.value), (Status::TargetReached, 138, 1));
    assert!(matches!(client.wait_event(Duration::from_millis(10)), Err(HostError::Timeout { received: 0, .. })));
}

#[test]
fn wait_event_reads_one_frame() {
    let mut client = client_answering(&[reply(Status::TargetReached, 138, 1)]);
    let got = client.wait_event(Duration::from_secs(1)).unwrap();
    assert_eq!(got.value, 1);
    assert!(client.transport_mut().sent.is_empty());
}

/// Command 137 sends no reply (§3.7.38); its value is the key 1234.
#[test]
fn factory_default_expects_no_reply() {
    let mut client = client_answering(&[]);
    client.factory_default().unwrap();
    assert_eq!(client.transport_mut().sent, [0x01, 0x89, 0x00, 0x00, 0x00, 0x00, 0x04, 0xD2, 0x60]);
}

// -- matching replies to requests (PD28-1021 manual §3.2, Table 3) ---------------------------------------

/// The case: module 1's late GAP reply must not answer a GAP to module 2.
#[test]
fn reply_from_another_address_is_skipped() {
    let late = reply_from(1, Status::Ok, 6, 1000);
    let mut client = client_answering(&[late, reply_from(2, Status::Ok, 6, 51200)]).with_module_address(2);
    assert_eq!(client.get_axis_parameter(5, 0).unwrap(), 51200);
    let skipped = client.take_skipped();
    assert_eq!((skipped.len(), skipped[0].module, skipped[0].value), (1, 1, 1000));
}

#[test]
fn only_a_foreign_reply_is_an_error_naming_it() {
    let mut client = client_answering(&[reply_from(1, Status::Ok, 6, 1000)]).with_module_address(2);
    let err = client.get_axis_parameter(5, 0).unwrap_err();
    match &err {
        HostError::Foreign { address: 2, opcode: 6, reply } => assert_eq!((reply.module, reply.value), (1, 1000)),
        other => panic!("expected a foreign reply, got {other:?}"),
    }
    assert!(err.is_bad_reply() && err.is_reply_error() && !err.is_status_error());
    let text = err.to_string();
    assert!(text.contains("no answer to GAP to module 2") && text.contains("module 1, command GAP"), "{text}");
    assert!(text.contains("value 1000") && text.contains("late reply"), "{text}");
}

#[test]
fn reply_with_another_command_number_is_foreign() {
    let mut client = client_answering(&[reply(Status::Ok, 5, 300)]);
    let err = client.get_axis_parameter(4, 0).unwrap_err();
    assert!(matches!(err, HostError::Foreign { opcode: 6, reply, .. } if reply.opcode == 5), "{err:?}");
}

#[test]
fn late_reply_to_the_same_command_is_drained_after_a_timeout() {
    // GAP 4 times out; its reply arrives before GAP 5 is sent. The two replies cannot be told apart (same
    // module, same command number), so the drain before GAP 5 must take it off the line.
    let mut client = client_answering(&[]).with_timeout(Duration::from_millis(5));
    assert!(matches!(client.get_axis_parameter(4, 0), Err(HostError::Timeout { received: 0, .. })));
    client.transport_mut().push_input(&reply(Status::Ok, 6, 1000));
    client.transport_mut().answer_next(&reply(Status::Ok, 6, 2000));
    assert_eq!(client.get_axis_parameter(5, 0).unwrap(), 2000);
    assert_eq!(client.take_skipped()[0].value, 1000);
}

#[test]
fn half_a_late_reply_then_the_rest_is_drained_as_one_frame() {
    let late = reply(Status::Ok, 6, 1000);
    let mut client = client_answering(&[]).with_timeout(Duration::from_millis(5));
    client.transport_mut().push_input(&late[..4]);
    assert!(matches!(client.get_axis_parameter(4, 0), Err(HostError::Timeout { received: 4, .. })));
    client.transport_mut().push_input(&late[4..]);
    client.settle().unwrap();
    assert_eq!(client.take_skipped(), [Reply::parse(&ReplyFrame::new_checked(&late[..]).unwrap()).unwrap()]);
    assert!(client.transport_mut().input.is_empty());
}

#[test]
fn garbage_before_a_reply_is_skipped() {
    let good = reply(Status::Ok, 6, 77);
    let mut bytes = vec![0x00, 0xFF, 0x13];
    bytes.extend_from_slice(&good);
    let mut client = client_answering(&[]);
    client.transport_mut().push_input(&bytes);
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 77);
    assert!(client.take_skipped().is_empty());
}

#[test]
fn damaged_request_is_answered_with_status_1_and_command_0() {
    let mut client = client_answering(&[reply(Status::WrongChecksum, 0, 0)]);
    let err = client.get_axis_parameter(1, 0).unwrap_err();
    assert!(matches!(err, HostError::Status { status: Status::WrongChecksum, .. }), "{err:?}");
}

#[test]
fn sgp_66_may_answer_from_the_new_address() {
    let mut client = client_answering(&[reply_from(7, Status::Ok, 9, 7)]).with_module_address(3);
    client.set_global_parameter(66, 0, 7).unwrap();
    // Any other parameter must come from the addressed module.
    let mut client = client_answering(&[reply_from(7, Status::Ok, 9, 7)]).with_module_address(3);
    assert!(matches!(client.set_global_parameter(65, 0, 7), Err(HostError::Foreign { .. })));
}

#[test]
fn match_address_off_accepts_any_module() {
    let mut client = client_answering(&[reply_from(1, Status::Ok, 6, 5)]).with_module_address(20);
    client.match_address = false;
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 5);
}

#[test]
fn version_string_skips_foreign_normal_replies() {
    let mut raw = [2u8; FRAME_LEN];
    raw[1..].copy_from_slice(b"1021V142");
    let mut client = client_answering(&[reply_from(3, Status::Ok, 136, 0x0A15_012A), raw]);
    assert_eq!(client.version_string().unwrap(), "1021V142");
    assert_eq!(client.take_skipped()[0].module, 3);
    let mut client = client_answering(&[reply_from(3, Status::Ok, 136, 0x0A15_012A)]);
    assert!(matches!(client.version_string(), Err(HostError::Foreign { .. })));
}

#[test]
fn event_during_a_drain_is_kept() {
    let mut client = client_answering(&[]).with_timeout(Duration::from_millis(5));
    assert!(client.get_axis_parameter(1, 0).is_err());
    client.transport_mut().push_input(&reply(Status::TargetReached, 138, 1));
    client.transport_mut().answer_next(&reply(Status::Ok, 6, 3));
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 3);
    assert_eq!(client.wait_event(Duration::ZERO).unwrap().value, 1);
}
