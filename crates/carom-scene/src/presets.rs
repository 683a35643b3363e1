//! Scenes built into the binary: the files in the repository's `scenes/` folder, so that
//! `carom run` works with no file at hand.

/// `(name, TOML text)` for every shipped scene; the first is the default.
pub const PRESETS: &[(&str, &str)] = &[
    (
        "lecture_100_k05",
        include_str!("../../../scenes/lecture_100_k05.toml"),
    ),
    (
        "lecture_100_k10",
        include_str!("../../../scenes/lecture_100_k10.toml"),
    ),
    (
        "lecture_example_1",
        include_str!("../../../scenes/lecture_example_1.toml"),
    ),
    (
        "lecture_example_2",
        include_str!("../../../scenes/lecture_example_2.toml"),
    ),
    (
        "lecture_5000_grid100",
        include_str!("../../../scenes/lecture_5000_grid100.toml"),
    ),
    (
        "lecture_5000_grid50",
        include_str!("../../../scenes/lecture_5000_grid50.toml"),
    ),
    (
        "lecture_5000_brute",
        include_str!("../../../scenes/lecture_5000_brute.toml"),
    ),
    (
        "lecture_mixed_radii",
        include_str!("../../../scenes/lecture_mixed_radii.toml"),
    ),
    (
        "newton_cradle",
        include_str!("../../../scenes/newton_cradle.toml"),
    ),
    (
        "newton_cradle_3d",
        include_str!("../../../scenes/newton_cradle_3d.toml"),
    ),
    (
        "pool_break",
        include_str!("../../../scenes/pool_break.toml"),
    ),
    (
        "settling_pile",
        include_str!("../../../scenes/settling_pile.toml"),
    ),
    (
        "lecture_pile_60hz",
        include_str!("../../../scenes/lecture_pile_60hz.toml"),
    ),
    (
        "pyramid_60hz",
        include_str!("../../../scenes/pyramid_60hz.toml"),
    ),
    (
        "hex_box_60hz",
        include_str!("../../../scenes/hex_box_60hz.toml"),
    ),
    ("box_3d", include_str!("../../../scenes/box_3d.toml")),
    (
        "periodic_gas",
        include_str!("../../../scenes/periodic_gas.toml"),
    ),
    (
        "periodic_slab_3d",
        include_str!("../../../scenes/periodic_slab_3d.toml"),
    ),
    (
        "inelastic_collapse",
        include_str!("../../../scenes/inelastic_collapse.toml"),
    ),
];

/// The preset `carom run` uses when given no scene.
pub const DEFAULT_PRESET: &str = "lecture_100_k05";

/// The TOML text of a preset, by name.
pub fn preset(name: &str) -> Option<&'static str> {
    PRESETS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
}

/// Names of all presets, in order.
pub fn preset_names() -> impl Iterator<Item = &'static str> {
    PRESETS.iter().map(|(n, _)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// Every file in `scenes/` is a preset of its own name, with its text (three were left
    /// out, and `carom presets` says it lists the files in scenes/).
    #[test]
    fn every_shipped_scene_is_a_preset() {
        let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let mut files = Vec::new();
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let name = path.file_stem().unwrap().to_str().unwrap().to_string();
                let text = std::fs::read_to_string(&path).unwrap();
                assert_eq!(preset(&name), Some(text.as_str()), "scenes/{name}.toml");
                files.push(name);
            }
        }
        assert_eq!(
            files.len(),
            PRESETS.len(),
            "presets without a file in scenes/"
        );
    }
}
