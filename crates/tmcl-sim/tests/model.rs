//! Model-based test: random writes, compactions and reopens applied to a `FileNvm` and to a plain `Vec` always agree.

use proptest::prelude::*;
use tmcl_core::hal::Nvm;
use tmcl_sim::nvm::ERASED;
use tmcl_sim::{FileNvm, MemNvm, NvmError, Options};

const CAPACITY: usize = 128;

#[derive(Debug, Clone)]
enum Op {
    /// May reach past the end: then both must refuse it.
    Write {
        offset: usize,
        data: Vec<u8>,
    },
    Reopen,
    Compact,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        10 => (0..CAPACITY + 8, prop::collection::vec(any::<u8>(), 0..24))
            .prop_map(|(offset, data)| Op::Write { offset, data }),
        2 => Just(Op::Reopen),
        1 => Just(Op::Compact),
    ]
}

fn image(nvm: &mut impl Nvm<Error = NvmError>) -> Vec<u8> {
    let mut buf = vec![0; nvm.capacity()];
    nvm.read(0, &mut buf).unwrap();
    buf
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn file_nvm_agrees_with_a_vec(
        ops in prop::collection::vec(op(), 1..80),
        compact_after in prop::option::of(0..1500usize),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("eeprom.bin");
        let options = Options { compact_after, ..Options::default() };
        let mut nvm = FileNvm::open_with(&path, CAPACITY, options).unwrap();
        let mut mem = MemNvm::new(CAPACITY);
        let mut model = vec![ERASED; CAPACITY];
        for op in ops {
            match op {
                Op::Write { offset, data } => {
                    let fits = offset + data.len() <= CAPACITY;
                    let file_result = nvm.write(offset, &data);
                    let mem_result = mem.write(offset, &data);
                    prop_assert_eq!(file_result.is_ok(), fits, "{:?}", file_result);
                    prop_assert_eq!(mem_result.is_ok(), fits, "{:?}", mem_result);
                    if fits {
                        model[offset..offset + data.len()].copy_from_slice(&data);
                    }
                }
                Op::Reopen => {
                    drop(nvm);
                    nvm = FileNvm::open_with(&path, CAPACITY, options).unwrap();
                    prop_assert_eq!(nvm.recovery().discarded_bytes, 0);
                }
                Op::Compact => nvm.compact().unwrap(),
            }
            prop_assert_eq!(&image(&mut nvm), &model);
            prop_assert_eq!(mem.image(), &model[..]);
        }
        drop(nvm);
        let mut nvm = FileNvm::open(&path, CAPACITY).unwrap();
        prop_assert_eq!(image(&mut nvm), model);
    }
}
