//! `carom run --trajectory PATH.pvd`: a `.vtp` per frame plus the `.pvd` collection.

use std::path::Path;
use std::process::Command;
use vtkio::model::{Attribute, DataSet, IOBuffer, Piece};

#[test]
fn pvd_trajectory_lists_whole_vtp_frames() {
    let dir = tempfile::tempdir().unwrap();
    let pvd = dir.path().join("t.pvd");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lecture_100_k05.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_carom"))
        .args([
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "45",
            "--trajectory",
        ])
        .arg(&pvd)
        .args(["--every", "10"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The collection: frames 0, 10, 20, 30, 40, each with its time, each file present.
    let text = std::fs::read_to_string(&pvd).unwrap();
    assert!(text.contains("<VTKFile type=\"Collection\""), "{text}");
    let files: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("<DataSet "))
        .map(|l| {
            let at = l.find("file=\"").unwrap() + 6;
            &l[at..at + l[at..].find('"').unwrap()]
        })
        .collect();
    assert_eq!(files.len(), 5, "{text}");
    assert!(text.contains("timestep=\"0\""), "{text}");
    for f in &files {
        assert!(dir.path().join(f).is_file(), "{f} listed but missing");
    }
    // No temporaries left next to the outputs.
    for d in [dir.path().to_path_buf(), dir.path().join("t")] {
        for e in std::fs::read_dir(d).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.ends_with(".tmp"), "{name}");
        }
    }

    // One frame, read back with vtkio: 100 points, a radius per point, 3-component velocity.
    let vtk = vtkio::Vtk::import(dir.path().join(files[4])).unwrap();
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        panic!("not PolyData");
    };
    let Piece::Inline(piece) = &pieces[0] else {
        panic!("not inline");
    };
    assert_eq!(piece.num_points(), 100);
    let array = |name: &str| {
        piece
            .data
            .point
            .iter()
            .find_map(|a| match a {
                Attribute::DataArray(d) if d.name == name => Some(d.data.clone()),
                _ => None,
            })
            .unwrap_or_else(|| panic!("no point array {name}"))
    };
    match array("radius") {
        IOBuffer::F64(r) => assert!(r.len() == 100 && r.iter().all(|&r| r == 4.0), "{r:?}"),
        other => panic!("radius: {other:?}"),
    }
    assert_eq!(array("velocity").len(), 300);
    assert_eq!(array("id").len(), 100);
}
