//! `carom validate --quick` on the real binary: carom's periodic gases against kinetic theory,
//! each within its tolerance (plain assertions on what it prints; no timing). The cases and
//! their formulas (docs/validation.md has the plots and the full-size figures):
//!
//! - Haff's law of homogeneous cooling, 2D and 3D, e = 0.95: `T(t) = T0 / (1 + t / t0)^2`,
//!   `t0 = 2 d / ((1 - e^2) w0)`, within 3 % over 2 t0;
//! - Enskog's collision frequency `w0 = 2 sqrt(pi) n s g(s) sqrt(T / m)` (2D),
//!   `4 sqrt(pi) n s^2 g(s) sqrt(T / m)` (3D), with `g(s) = (1 - 7 eta / 16) / (1 - eta)^2`
//!   (disks, Henderson 1975) and `(1 - eta / 2) / (1 - eta)^3` (spheres, Carnahan and
//!   Starling 1969): within 3 % at two packing fractions each;
//! - the equation of state at k = 1, `Z = P V / (N T)` against Henderson's
//!   `(1 + eta^2 / 8) / (1 - eta)^2` and Carnahan-Starling's
//!   `(1 + eta + eta^2 - eta^3) / (1 - eta)^3`: within 3 %;
//! - a k = 1 gas started with equal speeds relaxes to Maxwell-Boltzmann:
//!   `a2 = d / (d + 2) <v^4> / <v^2>^2 - 1` within 0.05 of 0.

use std::process::Command;

#[test]
fn every_validation_case_is_within_its_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_carom"))
        .args([
            "validate",
            "--quick",
            "--plots",
            dir.path().to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| l.ends_with(" ok") || l.ends_with("FAILED"))
        .collect();
    // 2 Haff, 4 equations of state and 4 collision frequencies, 1 Maxwell-Boltzmann
    assert_eq!(rows.len(), 11, "{stdout}");
    assert!(rows.iter().all(|r| r.ends_with(" ok")), "{stdout}");
    for plot in [
        "haff_2d.png",
        "haff_3d.png",
        "state_2d.png",
        "state_3d.png",
        "collision_rate_2d.png",
        "collision_rate_3d.png",
        "maxwell_2d.png",
    ] {
        let bytes = std::fs::read(dir.path().join(plot)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{plot}");
    }
}

#[test]
fn a_missing_plots_folder_is_refused_before_any_work() {
    let out = Command::new(env!("CARGO_BIN_EXE_carom"))
        .args(["validate", "--quick", "--plots", "/no/such/folder"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--plots"));
}
