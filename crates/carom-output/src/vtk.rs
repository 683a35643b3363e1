//! VTK trajectories for ParaView: `--trajectory PATH.pvd` writes one XML PolyData file (`.vtp`)
//! per frame into the folder `PATH` without `.pvd` (e.g. `run.pvd` -> `run/run_000000050.vtp`),
//! plus the `.pvd` collection listing every frame with its time.
//!
//! Each `.vtp` is written whole or not at all (through [`Files::write_whole`]) before the
//! collection lists it, so the collection only ever lists whole frames. The `.vtp` files are
//! made with the `vtkio` crate (points = positions, point data: `radius`, `velocity` (3
//! components; z = 0 in 2D), `id`); vtkio has no writer for `.pvd` collections, so that small
//! index is written here with `quick-xml`.
//!
//! The index grows linearly: it is written whole once (at the first frame, or when a resumed
//! run opens it), and every later frame overwrites only its closing tags with the new entry
//! and the closing tags again, in one positioned write of a few hundred bytes. A process killed
//! at any moment leaves the old index or the new one, both well-formed (a single write to a
//! regular file is not cut in two by the death of its process).

use crate::Files;
use carom_engine::{Vector, World};
use quick_xml::events::{BytesStart, Event};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use vtkio::model::{
    Attribute, Attributes, ByteOrder, DataArray, DataSet, ElementType, IOBuffer, PolyDataPiece,
    Version, VertexNumbers, Vtk,
};

/// The collection's opening lines.
const HEAD: &str = "<?xml version=\"1.0\"?>\n\
                    <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
                    <Collection>\n";

/// The collection's closing lines, overwritten by each new entry (and written after it again).
const TAIL: &str = "  </Collection>\n</VTKFile>\n";

/// One listed frame: step, time, file name relative to the `.pvd`.
#[derive(Debug, Clone, PartialEq)]
struct Entry {
    step: u64,
    time: f64,
    file: String,
}

impl Entry {
    /// The entry's line in the collection, attribute values escaped by quick-xml.
    fn line(&self) -> Vec<u8> {
        let time = self.time.to_string();
        let step = self.step.to_string();
        let mut element = BytesStart::new("DataSet");
        // `step` is carom's own attribute (ParaView ignores it); a resumed run reads it back.
        element.extend_attributes([
            ("timestep", time.as_str()),
            ("group", ""),
            ("part", "0"),
            ("file", self.file.as_str()),
            ("step", step.as_str()),
        ]);
        let mut line = b"    ".to_vec();
        quick_xml::Writer::new(&mut line)
            .write_event(Event::Empty(element))
            .expect("writing to memory");
        line.push(b'\n');
        line
    }
}

/// A `.vtp` series and its `.pvd` collection.
pub struct Series<F: Files> {
    pvd: PathBuf,
    folder: PathBuf,
    stem: String,
    entries: Vec<Entry>,
    /// The collection, open for its next entry, and its length (`None`: not written yet, or
    /// to be written whole again).
    index: Option<(std::fs::File, u64)>,
    files: F,
}

/// True for a path that asks for VTK output.
pub fn is_pvd(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pvd"))
}

impl<F: Files> Series<F> {
    /// Opens the series for a run at `steps_taken`: a fresh run (0) starts an empty collection;
    /// a resumed one keeps the frames an existing `.pvd` lists up to `steps_taken` (and writes
    /// the collection again with just those).
    pub fn open(pvd: &Path, steps_taken: u64, files: F) -> io::Result<Self> {
        let stem = pvd
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "trajectory".into());
        let folder = pvd.with_extension("");
        std::fs::create_dir_all(&folder)?;
        let mut series = Self {
            pvd: pvd.to_path_buf(),
            folder,
            stem,
            entries: Vec::new(),
            index: None,
            files,
        };
        if steps_taken > 0 {
            if let Ok(text) = std::fs::read_to_string(pvd) {
                series.entries = parse_pvd(&text);
                series.entries.retain(|e| e.step <= steps_taken);
                series.write_index()?;
            }
        }
        Ok(series)
    }

    /// Writes `world`'s current state as a frame, then lists it in the collection.
    pub fn frame<V: Vector>(&mut self, world: &World<V>) -> io::Result<()> {
        let step = world.steps_taken();
        let name = format!("{}_{step:09}.vtp", self.stem);
        let path = self.folder.join(&name);
        let vtk = polydata(world);
        self.files.write_whole(&path, |w| {
            vtk.write_xml(&mut *w)
                .map_err(|e| io::Error::other(format!("{e:?}")))
        })?;
        let folder_name = self
            .folder
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let entry = Entry {
            step,
            time: world.time(),
            file: format!("{folder_name}/{name}"),
        };
        let in_order = self.entries.last().is_none_or(|last| last.step < step);
        self.entries.retain(|e| e.step < step);
        self.entries.push(entry);
        match &mut self.index {
            Some((file, len)) if in_order => {
                let entry = self.entries.last().expect("just pushed");
                append(&self.files, file, len, entry)
            }
            _ => self.write_index(),
        }
    }

    /// Writes the whole collection (atomically) and opens it for the next entries.
    fn write_index(&mut self) -> io::Result<()> {
        let entries = &self.entries;
        self.files
            .write_whole(&self.pvd, |w| write_pvd(entries, w))?;
        let file = std::fs::OpenOptions::new().write(true).open(&self.pvd)?;
        let len = file.metadata()?.len();
        self.index = Some((file, len));
        Ok(())
    }
}

/// Lists `entry` in the collection `file` of length `len`: its line and the closing tags
/// again, written over the closing tags in one positioned write.
fn append<F: Files>(
    files: &F,
    file: &std::fs::File,
    len: &mut u64,
    entry: &Entry,
) -> io::Result<()> {
    use std::os::unix::fs::FileExt;
    let mut bytes = entry.line();
    let grown = bytes.len() as u64;
    bytes.extend_from_slice(TAIL.as_bytes());
    let at = *len - TAIL.len() as u64;
    files.append(|| file.write_all_at(&bytes, at))?;
    *len += grown;
    Ok(())
}

fn polydata<V: Vector>(world: &World<V>) -> Vtk {
    let n = world.len();
    let mut points = Vec::with_capacity(3 * n);
    let mut velocity = Vec::with_capacity(3 * n);
    let mut radius = Vec::with_capacity(n);
    for id in 0..n {
        let (x, v, r, _) = world.particle(id);
        for a in 0..3 {
            points.push(if a < V::DIM { x.get(a) } else { 0.0 });
            velocity.push(if a < V::DIM { v.get(a) } else { 0.0 });
        }
        radius.push(r);
    }
    let array = |name: &str, elem, data| {
        Attribute::DataArray(DataArray {
            name: name.into(),
            elem,
            data,
        })
    };
    Vtk {
        version: Version::Auto,
        title: String::new(),
        byte_order: ByteOrder::LittleEndian,
        file_path: None,
        data: DataSet::inline(PolyDataPiece {
            points: IOBuffer::F64(points),
            // one vertex cell per particle, so ParaView draws them without a filter
            verts: Some(VertexNumbers::XML {
                connectivity: (0..n as u64).collect(),
                offsets: (1..=n as u64).collect(),
            }),
            lines: None,
            polys: None,
            strips: None,
            data: Attributes {
                point: vec![
                    array(
                        "radius",
                        ElementType::Scalars {
                            num_comp: 1,
                            lookup_table: None,
                        },
                        IOBuffer::F64(radius),
                    ),
                    array("velocity", ElementType::Vectors, IOBuffer::F64(velocity)),
                    array(
                        "id",
                        ElementType::Generic(1),
                        IOBuffer::U32((0..n as u32).collect()),
                    ),
                ],
                cell: Vec::new(),
            },
        }),
    }
}

fn write_pvd(entries: &[Entry], w: &mut dyn Write) -> io::Result<()> {
    w.write_all(HEAD.as_bytes())?;
    for e in entries {
        w.write_all(&e.line())?;
    }
    w.write_all(TAIL.as_bytes())
}

/// The entries of a `.pvd` this module wrote: every `DataSet` element with readable `step`,
/// `timestep` and `file` attributes, up to the end or the first malformed XML.
fn parse_pvd(text: &str) -> Vec<Entry> {
    let mut reader = quick_xml::Reader::from_str(text);
    let mut entries = Vec::new();
    loop {
        match reader.read_event() {
            Ok(Event::Empty(e) | Event::Start(e)) if e.name().as_ref() == b"DataSet" => {
                if let Some(entry) = entry_of(&e) {
                    entries.push(entry);
                }
            }
            Ok(Event::Eof) | Err(_) => return entries,
            Ok(_) => {}
        }
    }
}

fn entry_of(element: &BytesStart) -> Option<Entry> {
    let value = |name: &[u8]| -> Option<String> {
        let attribute = element
            .attributes()
            .filter_map(Result::ok)
            .find(|a| a.key.as_ref() == name)?;
        Some(attribute.unescape_value().ok()?.into_owned())
    };
    Some(Entry {
        step: value(b"step")?.parse().ok()?,
        time: value(b"timestep")?.parse().ok()?,
        file: value(b"file")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries() -> Vec<Entry> {
        vec![
            Entry {
                step: 0,
                time: 0.0,
                file: "a/a_000000000.vtp".into(),
            },
            Entry {
                step: 10,
                time: 0.1,
                file: "a&b/\"x\"<y>.vtp".into(),
            },
        ]
    }

    #[test]
    fn pvd_round_trips() {
        let mut out = Vec::new();
        write_pvd(&entries(), &mut out).unwrap();
        let text = std::str::from_utf8(&out).unwrap();
        assert!(
            text.contains("file=\"a&amp;b/&quot;x&quot;&lt;y&gt;.vtp\""),
            "{text}"
        );
        assert_eq!(parse_pvd(text), entries());
    }

    #[test]
    fn the_format_is_the_one_carom_always_wrote() {
        let mut out = Vec::new();
        write_pvd(&entries()[..1], &mut out).unwrap();
        assert_eq!(
            std::str::from_utf8(&out).unwrap(),
            "<?xml version=\"1.0\"?>\n\
             <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
             <Collection>\n    \
             <DataSet timestep=\"0\" group=\"\" part=\"0\" file=\"a/a_000000000.vtp\" step=\"0\"/>\n  \
             </Collection>\n</VTKFile>\n"
        );
    }

    #[test]
    fn a_cut_collection_keeps_its_whole_entries() {
        let mut out = Vec::new();
        write_pvd(&entries(), &mut out).unwrap();
        let text = std::str::from_utf8(&out).unwrap();
        let cut = text.find("step=\"10\"").unwrap();
        assert_eq!(parse_pvd(&text[..cut]), entries()[..1]);
    }

    #[test]
    fn appending_gives_the_bytes_of_a_whole_rewrite() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.pvd");
        let all = entries();
        crate::write_atomic(&path, |w| write_pvd(&all[..1], w)).unwrap();
        let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        let mut len = file.metadata().unwrap().len();
        append(&crate::Atomic, &file, &mut len, &all[1]).unwrap();
        let mut whole = Vec::new();
        write_pvd(&all, &mut whole).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), whole);
        assert_eq!(len, whole.len() as u64);
    }
}
