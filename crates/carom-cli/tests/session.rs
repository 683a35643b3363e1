//! Long runs lose nothing: checkpoints, resume, Ctrl-C and SIGKILL, on the real binary, with
//! CSV and VTK (`.pvd` + `.vtp`) trajectories.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use vtkio::model::{Attribute, DataSet, Piece};

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lecture_5000_grid100.toml")
}

fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn straight_run(dir: &Path, steps: &str) -> Vec<u8> {
    let out = dir.join("straight.csv");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        steps,
        "--out",
        out.to_str().unwrap(),
    ]));
    std::fs::read(out).unwrap()
}

#[test]
fn checkpoint_then_resume_equals_a_straight_run() {
    let dir = tempfile::tempdir().unwrap();
    let expected = straight_run(dir.path(), "230");
    let ck = dir.path().join("ck.bin");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        "230",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "100",
    ]));
    // the checkpoint holds step 200; resume runs the last 30 steps
    let out = dir.path().join("resumed.csv");
    ok(carom().args([
        "resume",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_eq!(std::fs::read(&out).unwrap(), expected);
    // and on another thread count
    ok(carom().args([
        "resume",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]));
    assert_eq!(std::fs::read(&out).unwrap(), expected);
}

#[test]
fn damaged_or_foreign_checkpoints_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("ck.bin");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        "20",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "10",
    ]));
    let good = std::fs::read(&ck).unwrap();
    let mut cases: Vec<(Vec<u8>, &str)> = vec![
        (good[..good.len() / 2].to_vec(), "damaged"),
        (b"id,x,y\n".to_vec(), "not a carom checkpoint"),
    ];
    let mut flipped = good.clone();
    flipped[good.len() / 3] ^= 1;
    cases.push((flipped, "checksum"));
    let mut newer = good.clone();
    newer[8..12].copy_from_slice(&7u32.to_le_bytes());
    cases.push((newer, "version 7"));
    for (bytes, words) in cases {
        let bad = dir.path().join("bad.bin");
        std::fs::write(&bad, bytes).unwrap();
        let out = dir.path().join("never.csv");
        let o = carom()
            .args([
                "resume",
                bad.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("bad.bin") && err.contains(words),
            "{words}: {err}"
        );
        assert!(!out.exists());
    }
    let o = carom()
        .args(["resume", "/nonexistent/ck.bin"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn bad_long_run_flags_are_refused() {
    let s = scene();
    let s = s.to_str().unwrap();
    for args in [
        vec!["run", s, "--checkpoint", "ck.bin"],
        vec![
            "run",
            s,
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            "0",
        ],
        vec!["run", s, "--trajectory", "t.csv", "--every", "0"],
        vec![
            "run",
            s,
            "--trajectory",
            "/nonexistent/t.csv",
            "--every",
            "5",
        ],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let o = carom()
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{args:?} left a file"
        );
    }
}

/// Reads a trajectory CSV up to its last whole frame: (frames, particles per frame).
fn whole_frames(text: &str, particles: usize) -> Vec<u64> {
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "step,time,id,x,y,vx,vy,radius,mass");
    let rows: Vec<&str> = lines.collect();
    let mut frames = Vec::new();
    for frame in rows.chunks(particles) {
        let complete = frame.len() == particles
            && frame.iter().all(|l| {
                l.split(',').count() == 9 && l.split(',').all(|f| f.parse::<f64>().is_ok())
            });
        if !complete {
            break;
        }
        let step: u64 = frame[0].split(',').next().unwrap().parse().unwrap();
        assert!(frame.iter().all(|l| l.starts_with(&format!("{step},"))));
        frames.push(step);
    }
    frames
}

/// The trajectory of a long run: one CSV, or a `.pvd` collection of `.vtp` frames.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Traj {
    Csv,
    Vtk,
}

impl Traj {
    fn file(self) -> &'static str {
        match self {
            Traj::Csv => "traj.csv",
            Traj::Vtk => "traj.pvd",
        }
    }
}

/// How a long run is stopped.
#[derive(Clone, Copy, Debug)]
enum Stop {
    /// `kill -INT` or `kill -TERM`: a graceful stop, exit status 130.
    Signal(&'static str),
    /// SIGKILL: no chance to clean up.
    Kill,
}

/// How a run ended, which decides what it may leave behind.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ending {
    /// One SIGINT or SIGTERM: every file whole, the trajectory complete up to the last step.
    Graceful,
    /// A second SIGINT: no temporaries, no partial frame; a `.vtp` written but not yet listed
    /// may be there, whole.
    AtOnce,
    /// SIGKILL: temporaries may be left (never named like a real file), and a CSV trajectory
    /// may end in a partial frame.
    Killed,
}

/// A temporary of an atomic write (`carom_output::write_atomic`).
fn is_temporary(name: &str) -> bool {
    name.starts_with(".carom-") && name.ends_with(".tmp")
}

/// Polls `done` until it holds; fails if carom exits first (or nothing happens for ten minutes,
/// rather than hanging the suite).
fn wait_until(child: &mut Child, what: &str, done: impl Fn() -> bool) {
    let started = Instant::now();
    while !done() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("carom exited ({status}) before {what}");
        }
        assert!(
            started.elapsed() < Duration::from_secs(600),
            "no {what} after ten minutes"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// True once the first trajectory frame is whole on disk.
fn first_frame_written(dir: &Path, traj: Traj, particles: usize) -> bool {
    match traj {
        Traj::Csv => std::fs::read(dir.join("traj.csv"))
            .is_ok_and(|b| b.iter().filter(|&&c| c == b'\n').count() > particles),
        Traj::Vtk => dir.join("traj.pvd").exists(),
    }
}

fn signal(child: &Child, sig: &str) -> bool {
    Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success()
}

/// A delay in `0..max` ms that differs from run to run (printed, so a failure can be retried
/// at the same point).
fn random_ms(max: u64) -> u64 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    (nanos.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 24) % max
}

/// Runs the lecture's 5000 particles (checkpoint every 300 steps, trajectory every 100) and
/// stops it `after` the first trajectory frame is on disk; returns the trajectory's frames.
fn interrupted_run(dir: &Path, traj: Traj, stop: Stop, after: Duration) -> Vec<u64> {
    let s = scene();
    let mut child = carom()
        .args([
            "run",
            s.to_str().unwrap(),
            "--steps",
            "100000",
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            "300",
            "--trajectory",
            traj.file(),
            "--every",
            "100",
            "--out",
            "final.csv",
        ])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut child, "the first trajectory frame", || {
        first_frame_written(dir, traj, 5000)
    });
    std::thread::sleep(after);
    let ending = match stop {
        Stop::Signal(sig) => {
            assert!(signal(&child, sig));
            let out = child.wait_with_output().unwrap();
            assert_eq!(
                out.status.code(),
                Some(130),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            Ending::Graceful
        }
        Stop::Kill => {
            child.kill().unwrap(); // SIGKILL
            child.wait().unwrap();
            Ending::Killed
        }
    };
    let context = format!(
        "{traj:?}, {stop:?} {} ms after the first frame",
        after.as_millis()
    );
    let frames = check_files_on_disk(dir, traj, 5000, 100, ending, &context);
    assert!(!frames.is_empty(), "{context}");
    frames
}

/// Checks what a stopped run left in `dir`: no final output (the run never finished); the
/// checkpoint, if any, whole; the trajectory's frames 0, `every`, 2 `every`, ... each whole
/// (see [`Ending`] for what else may be there). Returns the trajectory's frames.
fn check_files_on_disk(
    dir: &Path,
    traj: Traj,
    particles: usize,
    every: u64,
    ending: Ending,
    context: &str,
) -> Vec<u64> {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        let expected = name == "ck.bin"
            || name == "heavy.toml"
            || name == traj.file()
            || (traj == Traj::Vtk && name == "traj")
            || (ending == Ending::Killed && is_temporary(&name));
        assert!(expected, "{context}: unexpected file {name}");
    }
    let ck = dir.join("ck.bin");
    if ck.exists() {
        let cp = carom_output::checkpoint::Checkpoint::read_from(&std::fs::read(&ck).unwrap())
            .unwrap_or_else(|e| panic!("{context}: checkpoint: {e}"));
        assert_eq!(cp.radii.len(), particles, "{context}");
    }
    let frames = match traj {
        Traj::Csv => {
            let text = std::fs::read_to_string(dir.join("traj.csv")).unwrap();
            csv_frames(&text, particles, ending != Ending::Killed, context)
        }
        Traj::Vtk => check_vtk_series(dir, particles, every, ending, context),
    };
    assert!(
        frames
            .iter()
            .enumerate()
            .all(|(k, &s)| s == every * k as u64),
        "{context}: {frames:?}"
    );
    frames
}

/// The frames of a trajectory CSV: whole frames only, and with `strict`, nothing after them.
fn csv_frames(text: &str, particles: usize, strict: bool, context: &str) -> Vec<u64> {
    let frames = whole_frames(text, particles);
    if strict {
        assert!(text.ends_with('\n'), "{context}: cut line");
        assert_eq!(
            text.lines().count(),
            1 + particles * frames.len(),
            "{context}: a partial frame after the whole ones"
        );
    }
    frames
}

/// Checks a `.vtp` frame file: it parses, and holds `particles` points with the point data
/// `radius`, `velocity` (3 components) and `id`.
fn check_vtp(path: &Path, particles: usize) -> Result<(), String> {
    let vtk = vtkio::Vtk::import(path).map_err(|e| format!("{}: {e:?}", path.display()))?;
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        return Err(format!("{}: not PolyData", path.display()));
    };
    let [Piece::Inline(piece)] = pieces.as_slice() else {
        return Err(format!("{}: not one inline piece", path.display()));
    };
    if piece.num_points() != particles {
        return Err(format!("{}: {} points", path.display(), piece.num_points()));
    }
    for (name, len) in [
        ("radius", particles),
        ("velocity", 3 * particles),
        ("id", particles),
    ] {
        let found = piece.data.point.iter().find_map(|a| match a {
            Attribute::DataArray(d) if d.name == name => Some(d.data.len()),
            _ => None,
        });
        if found != Some(len) {
            return Err(format!("{}: {name}: {found:?} values", path.display()));
        }
    }
    Ok(())
}

/// Checks a VTK series `traj.pvd` + `traj/`: the `.pvd` is whole, well-formed XML listing
/// frames 0, `every`, 2 `every`, ... with increasing times; every listed `.vtp` exists and
/// parses; any other file named like a frame is whole and valid (the next frame, written but
/// not yet listed; never after a graceful stop); temporaries only after SIGKILL. Returns the
/// listed steps.
fn check_vtk_series(
    dir: &Path,
    particles: usize,
    every: u64,
    ending: Ending,
    context: &str,
) -> Vec<u64> {
    let text = std::fs::read_to_string(dir.join("traj.pvd"))
        .unwrap_or_else(|e| panic!("{context}: traj.pvd: {e}"));
    let root = parse_xml(&text).unwrap_or_else(|e| panic!("{context}: traj.pvd: {e}\n{text}"));
    assert_eq!(root.name, "VTKFile", "{context}");
    assert_eq!(root.attr("type"), Some("Collection"), "{context}");
    let [collection] = root.children.as_slice() else {
        panic!("{context}: traj.pvd: not one <Collection>\n{text}");
    };
    assert_eq!(collection.name, "Collection", "{context}");
    let mut steps = Vec::new();
    let mut last_time = f64::NEG_INFINITY;
    for data in &collection.children {
        assert_eq!(data.name, "DataSet", "{context}");
        let step: u64 = data.attr("step").unwrap().parse().unwrap();
        let time: f64 = data.attr("timestep").unwrap().parse().unwrap();
        assert!(time > last_time, "{context}: times not increasing\n{text}");
        last_time = time;
        let file = data.attr("file").unwrap();
        assert_eq!(file, format!("traj/traj_{step:09}.vtp"), "{context}");
        check_vtp(&dir.join(file), particles)
            .unwrap_or_else(|e| panic!("{context}: listed frame: {e}"));
        steps.push(step);
    }
    assert!(
        steps
            .iter()
            .enumerate()
            .all(|(k, &s)| s == every * k as u64),
        "{context}: {steps:?}"
    );
    let next = steps.last().map_or(0, |s| s + every);
    for entry in std::fs::read_dir(dir.join("traj")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if ending == Ending::Killed && is_temporary(&name) {
            continue;
        }
        let step: u64 = name
            .strip_prefix("traj_")
            .and_then(|n| n.strip_suffix(".vtp"))
            .filter(|n| n.len() == 9)
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{context}: unexpected file traj/{name}"));
        if !steps.contains(&step) {
            // written whole but not yet listed: only the next frame, only if the run was stopped
            // between the frame and the collection
            assert!(
                ending != Ending::Graceful && step == next,
                "{context}: unlisted frame {name}"
            );
            check_vtp(&dir.join("traj").join(&name), particles)
                .unwrap_or_else(|e| panic!("{context}: unlisted frame: {e}"));
        }
    }
    steps
}

/// An XML element: name, attributes (entities resolved), child elements.
#[derive(Debug)]
struct Element {
    name: String,
    attrs: Vec<(String, String)>,
    children: Vec<Element>,
}

impl Element {
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// Parses `text` as one well-formed XML document (the subset VTK files use: an XML
/// declaration, comments, elements, quoted attributes, character and entity references, text);
/// anything else, a cut file included, is an error.
fn parse_xml(text: &str) -> Result<Element, String> {
    let mut p = XmlParser { s: text, at: 0 };
    if p.rest().starts_with("<?xml") {
        p.skip_past("?>")?;
    }
    p.misc()?;
    let root = p.element()?;
    p.misc()?;
    if p.at != text.len() {
        return Err(format!("content after the root element at byte {}", p.at));
    }
    Ok(root)
}

struct XmlParser<'a> {
    s: &'a str,
    at: usize,
}

impl<'a> XmlParser<'a> {
    fn rest(&self) -> &'a str {
        &self.s[self.at..]
    }

    fn eat(&mut self, token: &str) -> bool {
        let found = self.rest().starts_with(token);
        if found {
            self.at += token.len();
        }
        found
    }

    fn skip_ws(&mut self) -> bool {
        let n = self.rest().len() - self.rest().trim_start().len();
        self.at += n;
        n > 0
    }

    fn skip_past(&mut self, end: &str) -> Result<(), String> {
        let n = self
            .rest()
            .find(end)
            .ok_or_else(|| format!("no {end:?} after byte {}", self.at))?;
        self.at += n + end.len();
        Ok(())
    }

    /// Whitespace and comments.
    fn misc(&mut self) -> Result<(), String> {
        loop {
            self.skip_ws();
            if !self.eat("<!--") {
                return Ok(());
            }
            self.skip_past("-->")?;
        }
    }

    fn name(&mut self) -> Result<String, String> {
        let n = self
            .rest()
            .find(|c: char| !(c.is_ascii_alphanumeric() || "_:.-".contains(c)))
            .unwrap_or(self.rest().len());
        let name = &self.rest()[..n];
        if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
            return Err(format!("bad name at byte {}", self.at));
        }
        self.at += n;
        Ok(name.to_string())
    }

    /// Character data up to the next `<` (or `quote`), with entities resolved.
    fn chars(&mut self, until: char) -> Result<String, String> {
        let n = self.rest().find(['<', until]).unwrap_or(self.rest().len());
        let raw = &self.rest()[..n];
        let mut out = String::new();
        let mut parts = raw.split('&');
        out.push_str(parts.next().unwrap_or(""));
        for part in parts {
            let (entity, after) = part
                .split_once(';')
                .ok_or_else(|| format!("bad & near byte {}", self.at))?;
            let c = match entity {
                "amp" => '&',
                "lt" => '<',
                "gt" => '>',
                "quot" => '"',
                "apos" => '\'',
                _ => entity
                    .strip_prefix("#x")
                    .map(|h| u32::from_str_radix(h, 16))
                    .or_else(|| entity.strip_prefix('#').map(str::parse))
                    .and_then(Result::ok)
                    .and_then(char::from_u32)
                    .ok_or_else(|| format!("bad entity &{entity}; near byte {}", self.at))?,
            };
            out.push(c);
            out.push_str(after);
        }
        self.at += n;
        Ok(out)
    }

    fn element(&mut self) -> Result<Element, String> {
        if !self.eat("<") {
            return Err(format!("expected an element at byte {}", self.at));
        }
        let name = self.name()?;
        let mut element = Element {
            name,
            attrs: Vec::new(),
            children: Vec::new(),
        };
        loop {
            let spaced = self.skip_ws();
            if self.eat("/>") {
                return Ok(element);
            }
            if self.eat(">") {
                break;
            }
            if !spaced {
                return Err(format!("expected space or end of tag at byte {}", self.at));
            }
            let attr = self.name()?;
            self.skip_ws();
            if !self.eat("=") {
                return Err(format!("expected = at byte {}", self.at));
            }
            self.skip_ws();
            let quote = match self.rest().chars().next() {
                Some(q @ ('"' | '\'')) => q,
                _ => return Err(format!("expected a quoted value at byte {}", self.at)),
            };
            self.at += 1;
            let value = self.chars(quote)?;
            if !self.eat(&quote.to_string()) {
                return Err(format!("unterminated value of {attr} at byte {}", self.at));
            }
            if element.attr(&attr).is_some() {
                return Err(format!("attribute {attr} twice"));
            }
            element.attrs.push((attr, value));
        }
        loop {
            self.chars('<')?;
            if self.rest().is_empty() {
                return Err(format!("<{}> is never closed", element.name));
            }
            if self.eat("</") {
                let end = self.name()?;
                self.skip_ws();
                if end != element.name || !self.eat(">") {
                    return Err(format!("<{}> closed by </{end}", element.name));
                }
                return Ok(element);
            }
            if self.eat("<!--") {
                self.skip_past("-->")?;
                continue;
            }
            element.children.push(self.element()?);
        }
    }
}

#[test]
fn the_xml_checker_refuses_what_is_not_well_formed() {
    let good = "<?xml version=\"1.0\"?>\n<a x=\"1 &amp; 2\">\n  <b y='3'/>\n  <!-- c -->\n</a>\n";
    let root = parse_xml(good).unwrap();
    assert_eq!(root.attr("x"), Some("1 & 2"));
    assert_eq!(root.children[0].attr("y"), Some("3"));
    for bad in [
        "",
        "<a>",
        "<a><b></a>",
        "<a x=\"1></a>",
        "<a x=1/>",
        "<a/><b/>",
        "<a x=\"1\"y=\"2\"/>",
        "<a>&nope;</a>",
        "<a x=\"1\" x=\"2\"/>",
    ] {
        assert!(parse_xml(bad).is_err(), "{bad:?} accepted");
    }
    // every cut of a real collection but the whole one is refused
    let pvd = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  \
               <Collection>\n    <DataSet timestep=\"0\" file=\"t/t_000000000.vtp\" step=\"0\"/>\n  \
               </Collection>\n</VTKFile>\n";
    let whole = pvd.trim_end().len();
    for cut in 0..whole {
        assert!(parse_xml(&pvd[..cut]).is_err(), "cut at {cut} accepted");
    }
    assert!(parse_xml(pvd).is_ok());
}

#[test]
fn the_series_checker_refuses_damaged_or_stray_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(carom()
        .args(["run", scene().to_str().unwrap(), "--steps", "30"])
        .args(["--trajectory", "traj.pvd", "--every", "10"])
        .current_dir(d));
    assert_eq!(
        check_vtk_series(d, 5000, 10, Ending::Graceful, "clean"),
        [0, 10, 20, 30]
    );
    let fails = |ending: Ending| {
        std::panic::catch_unwind(|| check_vtk_series(d, 5000, 10, ending, "damaged")).is_err()
    };
    let frame = d.join("traj/traj_000000020.vtp");
    let bytes = std::fs::read(&frame).unwrap();
    // a listed frame cut short, or missing
    std::fs::write(&frame, &bytes[..bytes.len() / 2]).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::remove_file(&frame).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::write(&frame, &bytes).unwrap();
    assert!(!fails(Ending::Graceful));
    // the collection cut short
    let pvd = std::fs::read(d.join("traj.pvd")).unwrap();
    std::fs::write(d.join("traj.pvd"), &pvd[..pvd.len() - 20]).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::write(d.join("traj.pvd"), &pvd).unwrap();
    // a temporary: only after SIGKILL
    let tmp = d.join("traj/.carom-abc123.tmp");
    std::fs::write(&tmp, b"<?xml").unwrap();
    assert!(fails(Ending::AtOnce));
    assert!(!fails(Ending::Killed));
    std::fs::remove_file(&tmp).unwrap();
    // an unlisted next frame: whole, and not after a graceful stop; cut short, never
    let next = d.join("traj/traj_000000040.vtp");
    std::fs::write(&next, &bytes).unwrap();
    assert!(fails(Ending::Graceful));
    assert!(!fails(Ending::AtOnce));
    assert!(!fails(Ending::Killed));
    std::fs::write(&next, &bytes[..bytes.len() - 100]).unwrap();
    assert!(fails(Ending::Killed));
    // nor any other frame than the next
    std::fs::remove_file(&next).unwrap();
    std::fs::write(d.join("traj/traj_000000050.vtp"), &bytes).unwrap();
    assert!(fails(Ending::Killed));
}

#[test]
fn ctrl_c_and_sigterm_stop_cleanly_and_resume_exactly() {
    for (traj, sig) in [
        (Traj::Csv, "-INT"),
        (Traj::Csv, "-TERM"),
        (Traj::Vtk, "-INT"),
        (Traj::Vtk, "-TERM"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let after = random_ms(600);
        eprintln!("{traj:?} {sig} {after} ms after the first frame");
        let frames = interrupted_run(
            dir.path(),
            traj,
            Stop::Signal(sig),
            Duration::from_millis(after),
        );
        // the checkpoint holds the step the run stopped at; resume it to a short total and
        // compare with a straight run to the same total
        let ck = dir.path().join("ck.bin");
        let stopped_at = {
            let bytes = std::fs::read(&ck).unwrap();
            u64::from_le_bytes(bytes[16..24].try_into().unwrap())
        };
        assert!(stopped_at > 0);
        // and the trajectory holds every frame up to that step
        assert_eq!(
            frames.last(),
            Some(&(stopped_at / 100 * 100)),
            "{traj:?} {sig}"
        );
        let total = (stopped_at + 37).to_string();
        let expected = straight_run(dir.path(), &total);
        let out = dir.path().join("resumed.csv");
        ok(carom().args([
            "resume",
            ck.to_str().unwrap(),
            "--steps",
            &total,
            "--out",
            out.to_str().unwrap(),
        ]));
        assert_eq!(std::fs::read(&out).unwrap(), expected, "{traj:?} {sig}");
    }
}

fn sigkill_at_random_points(traj: Traj) {
    for ms in [0, 150, 420, 900, random_ms(1500)] {
        eprintln!("{traj:?}: SIGKILL {ms} ms after the first frame");
        let dir = tempfile::tempdir().unwrap();
        interrupted_run(dir.path(), traj, Stop::Kill, Duration::from_millis(ms));
        let ck = dir.path().join("ck.bin");
        if ck.exists() {
            // a checkpoint that exists is whole: it resumes, to the state a clean run reaches
            let out = dir.path().join("resumed.csv");
            let bytes = std::fs::read(&ck).unwrap();
            let at = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
            assert_eq!(at % 300, 0);
            let total = (at + 5).to_string();
            ok(carom().args([
                "resume",
                ck.to_str().unwrap(),
                "--steps",
                &total,
                "--out",
                out.to_str().unwrap(),
            ]));
            let clean = straight_run(dir.path(), &total);
            assert_eq!(
                std::fs::read(&out).unwrap(),
                clean,
                "{traj:?} killed {ms} ms after the first frame"
            );
        }
    }
}

#[test]
fn sigkill_at_random_points_leaves_only_whole_files_csv() {
    sigkill_at_random_points(Traj::Csv);
}

#[test]
fn sigkill_at_random_points_leaves_only_whole_files_vtk() {
    sigkill_at_random_points(Traj::Vtk);
}

/// A scene heavy enough that some file is being written at almost any moment.
const HEAVY: &str = r#"
name = "heavy output"
dimensions = 2
dt = 0.005
steps = 1000000
gravity = [0.0, -9.8]
restitution = 1.0

[domain]
min = [-100.0, -100.0]
max = [100.0, 100.0]
walls = true

[[fill]]
count = 60000
radius = 0.25
speed = 20.0
seed = 11
"#;

/// Particles in [`HEAVY`].
const HEAVY_N: usize = 60000;

/// Starts [`HEAVY`] in `d` with a trajectory frame every step and a checkpoint every step or
/// three, so that some file is always being written (fewer checkpoints with a CSV, so that
/// more signals land in a frame), and waits until the first checkpoint is on disk.
fn start_heavy_run(d: &Path, traj: Traj) -> Child {
    std::fs::write(d.join("heavy.toml"), HEAVY).unwrap();
    let checkpoint_every = match traj {
        Traj::Csv => "3",
        Traj::Vtk => "1",
    };
    let mut child = carom()
        .args(["run", "heavy.toml", "--out", "final.csv"])
        .args([
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            checkpoint_every,
        ])
        .args(["--trajectory", traj.file(), "--every", "1"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut child, "the first checkpoint", || {
        d.join("ck.bin").exists()
    });
    child
}

/// Ctrl-C twice: the first asks for a graceful stop (carom says so on stderr), the second,
/// sent as soon as carom has said it, quits at once. Returns whether it did (rather than the
/// graceful stop finishing first) after checking the exit status and the files.
fn double_ctrl_c(traj: Traj, attempt: u32) -> bool {
    const N: usize = HEAVY_N;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = start_heavy_run(d, traj);
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in std::io::BufReader::new(stderr).lines() {
            let line = line.unwrap();
            all.push_str(&line);
            all.push('\n');
            let _ = tx.send(line);
        }
        all
    });
    assert!(signal(&child, "-INT"));
    // wait for carom to have taken the first one, so the two cannot merge into one signal
    loop {
        match rx.recv_timeout(Duration::from_secs(600)) {
            Ok(line) if line.contains("interrupted: stopping") => break,
            Ok(_) => {}
            Err(e) => panic!("carom never acknowledged the first Ctrl-C ({e})"),
        }
    }
    signal(&child, "-INT"); // may come too late: the graceful stop may be done already
    let status = child.wait().unwrap();
    let err = reader.join().unwrap();
    let context = format!("{traj:?}, attempt {attempt}: {err}");
    assert_eq!(status.code(), Some(130), "{context}");
    let at_once = err.contains("interrupted again: quitting at once");
    // no temporaries anywhere, and every file there is whole
    let frames = check_files_on_disk(d, traj, N, 1, Ending::AtOnce, &context);
    let ck = d.join("ck.bin");
    let bytes = std::fs::read(&ck).unwrap();
    let at = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    assert!(at >= 1, "{context}");
    eprintln!(
        "{traj:?}, attempt {attempt}: {}, checkpoint at step {at}, frames 0..={}",
        if at_once {
            "quit at once"
        } else {
            "graceful stop first"
        },
        frames.last().unwrap()
    );
    // the checkpoint resumes
    ok(carom().current_dir(d).args([
        "resume",
        "ck.bin",
        "--steps",
        &(at + 1).to_string(),
        "--out",
        "resumed.csv",
    ]));
    let resumed = std::fs::read_to_string(d.join("resumed.csv")).unwrap();
    let (_, rows) = carom_output::read_state_csv(&resumed).unwrap();
    assert_eq!(rows.len(), N, "{context}");
    at_once
}

fn second_ctrl_c_quits_at_once(traj: Traj) {
    // The second Ctrl-C is sent as soon as carom has acknowledged the first; the graceful stop
    // rarely finishes before it lands, but it may on a loaded machine. Every attempt, either
    // way, must leave only whole files and exit with 130; at least one must have quit at once.
    // Several attempts, because each lands at another point of the writes.
    let mut at_once = 0;
    for attempt in 1..=8 {
        at_once += double_ctrl_c(traj, attempt) as u32;
        if attempt >= 4 && at_once > 0 {
            break;
        }
    }
    assert!(at_once > 0, "the second Ctrl-C never quit at once");
}

#[test]
fn second_ctrl_c_quits_at_once_leaving_whole_files_csv() {
    second_ctrl_c_quits_at_once(Traj::Csv);
}

#[test]
fn second_ctrl_c_quits_at_once_leaving_whole_files_vtk() {
    second_ctrl_c_quits_at_once(Traj::Vtk);
}

/// SIGKILL while files are being written all the time: whatever is on disk is whole.
fn sigkill_during_heavy_writes(traj: Traj) {
    for attempt in 1..=4 {
        let ms = random_ms(300);
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut child = start_heavy_run(d, traj);
        std::thread::sleep(Duration::from_millis(ms));
        child.kill().unwrap();
        child.wait().unwrap();
        let context =
            format!("{traj:?}, attempt {attempt}: SIGKILL {ms} ms after the first checkpoint");
        let frames = check_files_on_disk(d, traj, HEAVY_N, 1, Ending::Killed, &context);
        eprintln!("{context}: frames 0..={}", frames.last().unwrap());
    }
}

#[test]
fn sigkill_during_heavy_writes_leaves_only_whole_files_csv() {
    sigkill_during_heavy_writes(Traj::Csv);
}

#[test]
fn sigkill_during_heavy_writes_leaves_only_whole_files_vtk() {
    sigkill_during_heavy_writes(Traj::Vtk);
}
