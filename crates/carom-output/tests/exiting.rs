//! A process exiting at once (a second Ctrl-C) leaves no temporary behind, even of a write
//! that was about to begin. In a test binary of its own: it closes the process-wide writes.

use carom_output::{remove_in_flight_temporaries, write_atomic};

#[test]
fn no_file_is_started_once_the_temporaries_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let before = dir.path().join("before.txt");
    write_atomic(&before, |w| w.write_all(b"whole")).unwrap();
    assert_eq!(std::fs::read(&before).unwrap(), b"whole");

    remove_in_flight_temporaries();
    let after = dir.path().join("after.txt");
    let refused = write_atomic(&after, |w| w.write_all(b"never"));
    assert!(refused.is_err());
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(left, ["before.txt"], "no temporary, no target");
}
