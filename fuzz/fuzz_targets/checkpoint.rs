//! Arbitrary bytes -> checkpoint reader: refused with a message or read, never a panic or an
//! allocation larger than the input. An accepted checkpoint writes back to the same bytes.
#![no_main]

use carom_output::checkpoint::Checkpoint;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(cp) = Checkpoint::read_from(data) {
        let mut again = Vec::new();
        cp.write_to(&mut again).expect("writing to memory");
        assert_eq!(
            again, data,
            "an accepted checkpoint round-trips byte for byte"
        );
    }
});
