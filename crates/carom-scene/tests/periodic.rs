//! `[domain] periodic`: parsed, checked, and honoured by fills.

use carom_engine::glam::DVec2;
use carom_scene::{parse, AnyScene};

/// Explicit particles near (and beyond) the faces, and a dense fill over a region wider than
/// the domain on x: its candidates wrap into the box, right up to both faces.
const SCENE: &str = r#"
dimensions = 2
dt = 0.01
[domain]
min = [0.0, 0.0]
max = [20.0, 20.0]
periodic = [true, true]
[[particles]]
position = [19.8, 10.0]
radius = 1.0
[[particles]]
position = [25.0, 21.0]
radius = 1.0
[[fill]]
count = 150
radius = 0.5
seed = 4
min = [-6.0, 0.0]
max = [26.0, 20.0]
"#;

fn two(text: &str) -> carom_scene::Scene<DVec2> {
    match parse(text, "test.toml").unwrap() {
        AnyScene::Two(s) => s,
        AnyScene::Three(_) => unreachable!(),
    }
}

#[test]
fn fills_do_not_overlap_across_the_seams() {
    let scene = two(SCENE);
    assert_eq!(scene.config.periodic, [true, true, false]);
    let p = &scene.particles;
    // wrapped into the box, explicit particles included
    assert_eq!(p.positions()[1], DVec2::new(5.0, 1.0));
    assert!(p
        .positions()
        .iter()
        .all(|x| (0.0..20.0).contains(&x.x) && (0.0..20.0).contains(&x.y)));
    // no pair overlaps, seen through the minimum image
    let image = |d: f64| d - 20.0 * (d / 20.0).round();
    let mut near_seam = 0;
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = p.positions()[i] - p.positions()[j];
            let (dx, dy) = (image(d.x), image(d.y));
            let reach = p.radii()[i] + p.radii()[j];
            assert!(dx.hypot(dy) >= reach, "{i} and {j} overlap across a seam");
            if dx.hypot(dy) < reach + 1.0 && (dx != d.x || dy != d.y) {
                near_seam += 1;
            }
        }
    }
    assert!(near_seam > 0, "the fill must crowd the seams");
    let world = scene.build_world().unwrap();
    assert!(world.planes().is_empty());
    assert!(world.config().periodic().is_some());
}

#[test]
fn bad_periodic_values_name_the_field() {
    for bad in [
        "periodic = [true]",
        "periodic = [true, true, true]",
        "periodic = [true, 1]",
        "periodic = \"x\"",
    ] {
        let text = SCENE.replace("periodic = [true, true]", bad);
        let e = parse(&text, "test.toml").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("domain.periodic"), "{bad}: {e}");
        assert!(e.to_string().starts_with("test.toml: "), "{e}");
    }
    let hash = format!("{}\n[broadphase]\nkind = \"hash\"\n", SCENE);
    let e = parse(&hash, "test.toml").unwrap_err();
    assert_eq!(e.field.as_deref(), Some("broadphase.kind"), "{e}");
    // not periodic: walls everywhere, the hash by default
    let plain = two(&SCENE.replace("periodic = [true, true]", "periodic = [false, false]"));
    assert_eq!(plain.config.periodic, [false; 3]);
    assert!(plain.build_world().unwrap().config().periodic().is_none());
}
