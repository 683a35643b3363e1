//! VTK trajectories for ParaView: `--trajectory PATH.pvd` writes one XML PolyData file (`.vtp`)
//! per frame into the folder `PATH` without `.pvd` (e.g. `run.pvd` -> `run/run_000000050.vtp`),
//! plus the `.pvd` collection listing every frame with its time.
//!
//! Each `.vtp` is written atomically, and the `.pvd` is rewritten atomically after it, so the
//! collection only ever lists whole frames. The `.vtp` files are made with the `vtkio` crate
//! (points = positions, point data: `radius`, `velocity` (3 components; z = 0 in 2D), `id`);
//! vtkio has no writer for `.pvd` collections, so that small index is written here.

use carom_engine::{Vector, World};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use vtkio::model::{
    Attribute, Attributes, ByteOrder, DataArray, DataSet, ElementType, IOBuffer, PolyDataPiece,
    Version, VertexNumbers, Vtk,
};

/// One listed frame: step, time, file name relative to the `.pvd`.
#[derive(Debug, Clone, PartialEq)]
struct Entry {
    step: u64,
    time: f64,
    file: String,
}

/// A `.vtp` series and its `.pvd` collection.
pub struct Series {
    pvd: PathBuf,
    folder: PathBuf,
    stem: String,
    entries: Vec<Entry>,
}

/// True for a path that asks for VTK output.
pub fn is_pvd(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pvd"))
}

impl Series {
    /// Opens the series for a run at `steps_taken`: a fresh run (0) starts an empty collection;
    /// a resumed one keeps the frames an existing `.pvd` lists up to `steps_taken`.
    pub fn open(pvd: &Path, steps_taken: u64) -> io::Result<Self> {
        let stem = pvd
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "trajectory".into());
        let folder = pvd.with_extension("");
        std::fs::create_dir_all(&folder)?;
        let mut entries = Vec::new();
        if steps_taken > 0 {
            if let Ok(text) = std::fs::read_to_string(pvd) {
                entries = parse_pvd(&text)
                    .into_iter()
                    .filter(|e| e.step <= steps_taken)
                    .collect();
            }
        }
        Ok(Self {
            pvd: pvd.to_path_buf(),
            folder,
            stem,
            entries,
        })
    }

    /// Writes `world`'s current state as a frame, then the collection listing it.
    pub fn frame<V: Vector>(&mut self, world: &World<V>) -> io::Result<()> {
        let step = world.steps_taken();
        let name = format!("{}_{step:09}.vtp", self.stem);
        let path = self.folder.join(&name);
        let vtk = polydata(world);
        crate::session::write_whole(&path, |w| {
            vtk.write_xml(&mut *w)
                .map_err(|e| io::Error::other(format!("{e:?}")))
        })?;
        let folder_name = self
            .folder
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        self.entries.retain(|e| e.step < step);
        self.entries.push(Entry {
            step,
            time: world.time(),
            file: format!("{folder_name}/{name}"),
        });
        let entries = &self.entries;
        crate::session::write_whole(&self.pvd, |w| write_pvd(entries, w))
    }
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
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">"
    )?;
    writeln!(w, "  <Collection>")?;
    for e in entries {
        // `step` is carom's own attribute (ParaView ignores it); resume reads it back.
        writeln!(
            w,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\" step=\"{}\"/>",
            e.time,
            xml_escape(&e.file),
            e.step
        )?;
    }
    writeln!(w, "  </Collection>")?;
    writeln!(w, "</VTKFile>")
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn xml_unescape(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

fn attribute<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = line.find(&key)? + key.len();
    let len = line[start..].find('"')?;
    Some(&line[start..start + len])
}

/// The entries of a `.pvd` this module wrote (lines it cannot read are dropped).
fn parse_pvd(text: &str) -> Vec<Entry> {
    text.lines()
        .filter(|l| l.trim_start().starts_with("<DataSet "))
        .filter_map(|l| {
            Some(Entry {
                step: attribute(l, "step")?.parse().ok()?,
                time: attribute(l, "timestep")?.parse().ok()?,
                file: xml_unescape(attribute(l, "file")?),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pvd_round_trips() {
        let entries = vec![
            Entry {
                step: 0,
                time: 0.0,
                file: "a/a_000000000.vtp".into(),
            },
            Entry {
                step: 10,
                time: 0.1,
                file: "a&b/\"x\".vtp".into(),
            },
        ];
        let mut out = Vec::new();
        write_pvd(&entries, &mut out).unwrap();
        assert_eq!(parse_pvd(std::str::from_utf8(&out).unwrap()), entries);
    }
}
