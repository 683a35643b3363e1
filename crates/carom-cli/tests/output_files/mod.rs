//! What a run leaves on disk, checked: trajectory CSVs, VTK series (`.pvd` + `.vtp`) and
//! checkpoints, whole or cut, after a clean stop, a second Ctrl-C or SIGKILL.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::path::Path;
use vtkio::model::{Attribute, DataSet, Piece};

/// Reads a trajectory CSV up to its last whole frame; returns the step of each whole frame.
pub fn whole_frames(text: &str, particles: usize) -> Vec<u64> {
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
pub enum Traj {
    Csv,
    Vtk,
}

impl Traj {
    pub fn file(self) -> &'static str {
        match self {
            Traj::Csv => "traj.csv",
            Traj::Vtk => "traj.pvd",
        }
    }
}

/// How a run ended, which decides what it may leave behind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ending {
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
pub fn is_temporary(name: &str) -> bool {
    name.starts_with(".carom-") && name.ends_with(".tmp")
}

/// Checks what a stopped run left in `dir`: no final output (the run never finished); the
/// checkpoint, if any, whole; the trajectory's frames 0, `every`, 2 `every`, ... each whole
/// (see [`Ending`] for what else may be there). Returns the trajectory's frames.
pub fn check_files_on_disk(
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
    assert_every(&frames, every, context);
    frames
}

/// Asserts that `steps` are 0, `every`, 2 `every`, ...
fn assert_every(steps: &[u64], every: u64, context: &str) {
    assert!(
        steps
            .iter()
            .enumerate()
            .all(|(k, &s)| s == every * k as u64),
        "{context}: {steps:?}"
    );
}

/// The frames of a trajectory CSV: whole frames only, and with `strict`, nothing after them.
pub fn csv_frames(text: &str, particles: usize, strict: bool, context: &str) -> Vec<u64> {
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
pub fn check_vtp(path: &Path, particles: usize) -> Result<(), String> {
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
pub fn check_vtk_series(
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
    assert_every(&steps, every, context);
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
pub struct Element {
    pub name: String,
    attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}
/// Parses `text` as one well-formed XML document with quick-xml (end tags matching their start
/// tags, attributes quoted and not repeated, entities known); anything else, a cut file
/// included, is an error.
pub fn parse_xml(text: &str) -> Result<Element, String> {
    let mut reader = Reader::from_str(text);
    let mut open: Vec<Element> = Vec::new();
    let mut root = None;
    loop {
        let at = reader.buffer_position();
        let event = reader.read_event().map_err(|e| format!("byte {at}: {e}"))?;
        let closed = match event {
            Event::Start(tag) => {
                open.push(element(&tag)?);
                None
            }
            Event::Empty(tag) => Some(element(&tag)?),
            Event::End(_) => Some(open.pop().ok_or(format!("byte {at}: end tag of nothing"))?),
            Event::Text(text) => {
                let text = text.unescape().map_err(|e| format!("byte {at}: {e}"))?;
                if open.is_empty() && !text.trim().is_empty() {
                    return Err(format!("byte {at}: text outside the root element"));
                }
                None
            }
            Event::CData(_) if open.is_empty() => {
                return Err(format!("byte {at}: CDATA outside the root element"));
            }
            Event::Eof => break,
            // (the declaration, comments, processing instructions)
            _ => None,
        };
        if let Some(closed) = closed {
            match open.last_mut() {
                Some(parent) => parent.children.push(closed),
                None if root.is_none() => root = Some(closed),
                None => return Err(format!("byte {at}: content after the root element")),
            }
        }
    }
    if let Some(unclosed) = open.last() {
        return Err(format!("<{}> is not closed", unclosed.name));
    }
    root.ok_or_else(|| "no root element".to_string())
}

/// The element a start tag opens, its attributes checked and their entities resolved.
fn element(tag: &BytesStart) -> Result<Element, String> {
    let text = |bytes: &[u8]| String::from_utf8(bytes.to_vec()).map_err(|e| e.to_string());
    let mut attrs = Vec::new();
    for attr in tag.attributes().with_checks(true) {
        let attr =
            attr.map_err(|e| format!("<{}>: {e}", String::from_utf8_lossy(tag.name().as_ref())))?;
        let value = attr.unescape_value().map_err(|e| e.to_string())?;
        attrs.push((text(attr.key.as_ref())?, value.into_owned()));
    }
    Ok(Element {
        name: text(tag.name().as_ref())?,
        attrs,
        children: Vec::new(),
    })
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
        "<a>text</a> after",
        "</a>",
        "<a>&nope;</a>",
        "<a x=\"1\" x=\"2\"/>",
    ] {
        assert!(parse_xml(bad).is_err(), "{bad:?} accepted");
    }
    // (quick-xml lets `<a x="1"y="2"/>` through, attributes without a space between them:
    // a cut never makes one, and the writer, quick-xml's own, always puts the space in)
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
