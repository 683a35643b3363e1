//! Scenes the walls cannot hold (issue 13): a particle outside a walled domain, a particle
//! wider than the walled box, a `[[fill]]` region reaching outside the walls. Each is refused
//! with an error naming the field; the same particles without walls, or across a periodic
//! axis, are accepted as before.

use carom_scene::{parse, SceneError, MAX_STEPS};

fn box_2d(walls: bool, periodic: &str, body: &str) -> String {
    format!(
        "dimensions = 2\ndt = 0.01\n[domain]\nmin = [-10.0, -10.0]\nmax = [10.0, 10.0]\n\
         walls = {walls}\n{periodic}\n{body}"
    )
}

fn refused(text: &str) -> SceneError {
    parse(text, "bad.toml").expect_err("the scene should be refused")
}

fn field(e: &SceneError) -> &str {
    e.field.as_deref().unwrap_or("")
}

#[test]
fn a_particle_outside_the_walls_is_refused() {
    let particle = "[[particles]]\nposition = [15.0, 0.0]\nradius = 1.0\n";
    let e = refused(&box_2d(true, "", particle));
    assert_eq!(field(&e), "particles[0].position", "{e}");
    let text = e.to_string();
    assert!(
        text.starts_with("bad.toml: field `particles[0].position`"),
        "{text}"
    );
    assert!(
        text.contains("x = 15.0") && text.contains("[-9.0, 9.0]"),
        "{text}"
    );
    // half out (the centre inside, the disc through the wall) is outside too
    let e = refused(&box_2d(
        true,
        "",
        "[[particles]]\nposition = [0.0, -9.5]\nradius = 1.0\n",
    ));
    assert_eq!(field(&e), "particles[0].position", "{e}");
    assert!(e.to_string().contains("y = -9.5"), "{e}");
    // the second particle is the one named
    let e = refused(&box_2d(
        true,
        "",
        "[[particles]]\nposition = [0.0, 0.0]\nradius = 1.0\n\
         [[particles]]\nposition = [0.0, 10.5]\nradius = 1.0\n",
    ));
    assert_eq!(field(&e), "particles[1].position", "{e}");
}

#[test]
fn the_same_particles_are_accepted_without_walls_or_across_a_periodic_axis() {
    let particle = "[[particles]]\nposition = [15.0, 0.0]\nradius = 1.0\n";
    assert!(parse(&box_2d(false, "", particle), "ok.toml").is_ok());
    // periodic on x: the walls close only y, and x wraps into the box
    assert!(parse(
        &box_2d(true, "periodic = [true, false]", particle),
        "ok.toml"
    )
    .is_ok());
    // touching a wall exactly is inside
    let touching = "[[particles]]\nposition = [9.0, -9.0]\nradius = 1.0\n";
    assert!(parse(&box_2d(true, "", touching), "ok.toml").is_ok());
}

#[test]
fn a_particle_wider_than_the_walled_box_is_refused() {
    let e = refused(&box_2d(
        true,
        "",
        "[[particles]]\nposition = [0.0, 0.0]\nradius = 10.5\n",
    ));
    assert_eq!(field(&e), "particles[0].radius", "{e}");
    assert!(e.to_string().contains("wider than the walled box"), "{e}");
    // 3D, only the z side too short
    let e = refused(
        "dimensions = 3\ndt = 0.01\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [10.0, 10.0, 1.0]\n\
         walls = true\n[[particles]]\nposition = [5.0, 5.0, 0.5]\nradius = 0.6\n",
    );
    assert_eq!(field(&e), "particles[0].radius", "{e}");
    assert!(e.to_string().contains("z side is 1 long"), "{e}");
}

#[test]
fn a_fill_region_outside_the_walls_is_refused() {
    let fill = |min: &str, max: &str| {
        box_2d(
            true,
            "",
            &format!("[[fill]]\ncount = 5\nradius = 0.5\nmin = {min}\nmax = {max}\n"),
        )
    };
    let e = refused(&fill("[20.0, 20.0]", "[30.0, 30.0]"));
    assert_eq!(field(&e), "fill[0].max", "{e}");
    let e = refused(&fill("[-12.0, -5.0]", "[5.0, 5.0]"));
    assert_eq!(field(&e), "fill[0].min", "{e}");
    assert!(e.to_string().contains("x = -12"), "{e}");
    // inside, or the whole domain, is fine
    assert!(parse(&fill("[-10.0, -10.0]", "[10.0, 10.0]"), "ok.toml").is_ok());
    assert!(parse(&fill("[-5.0, -5.0]", "[5.0, 5.0]"), "ok.toml").is_ok());
    // without walls a region may reach past the domain
    let open = box_2d(
        false,
        "",
        "[[fill]]\ncount = 5\nradius = 0.5\nmin = [20.0, 20.0]\nmax = [30.0, 30.0]\n",
    );
    assert!(parse(&open, "ok.toml").is_ok());
}

#[test]
fn steps_are_bounded() {
    let scene = |steps: &str| format!("dimensions = 2\ndt = 0.01\nsteps = {steps}\n");
    assert!(parse(&scene(&MAX_STEPS.to_string()), "ok.toml").is_ok());
    let e = refused(&scene(&(MAX_STEPS + 1).to_string()));
    assert_eq!(field(&e), "steps", "{e}");
    let e = refused(&scene("-1"));
    assert_eq!(field(&e), "steps", "{e}");
}

#[test]
fn every_shipped_scene_is_still_accepted() {
    for (name, text) in carom_scene::PRESETS {
        parse(text, name).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn particles_behind_a_plane_are_refused() {
    let scene = |body: &str| {
        format!(
            "dimensions = 2\ndt = 0.01\n[[planes]]\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n\
             {body}"
        )
    };
    // behind the floor (a sign typo in the normal does this to every particle)
    let e = refused(&scene(
        "[[particles]]\nposition = [0.0, -5.0]\nradius = 1.0\n",
    ));
    assert_eq!(field(&e), "particles[0].position", "{e}");
    assert!(e.to_string().contains("behind planes[0]"), "{e}");
    // partly through it
    let e = refused(&scene(
        "[[particles]]\nposition = [0.0, 0.5]\nradius = 1.0\n",
    ));
    assert!(e.to_string().contains("partly behind planes[0]"), "{e}");
    // resting on it is fine
    assert!(parse(
        &scene("[[particles]]\nposition = [3.0, 1.0]\nradius = 1.0\n"),
        "ok"
    )
    .is_ok());
    // a fill whose region reaches below the floor
    let e = refused(&scene(
        "[[fill]]\ncount = 20\nradius = 0.5\nmin = [-10.0, -10.0]\nmax = [10.0, 10.0]\n",
    ));
    assert_eq!(field(&e), "fill[0]", "{e}");
    assert!(parse(
        &scene("[[fill]]\ncount = 20\nradius = 0.5\nmin = [-10.0, 0.0]\nmax = [10.0, 10.0]\n"),
        "ok"
    )
    .is_ok());
}

/// A number out of range is shown as it was written, not as its decimal expansion (`1e308`,
/// not 309 digits), in every message that quotes a value.
#[test]
fn numbers_out_of_range_are_shown_short() {
    let particle =
        |radius: &str| format!("[[particles]]\nposition = [0.0, 0.0]\nradius = {radius}\n");
    let cases = [
        (
            box_2d(false, "", &particle("1e308")),
            "1e308 is out of carom's range",
        ),
        (
            box_2d(false, "", &particle("1e-300")),
            "1e-300 is out of carom's range",
        ),
        (
            "dimensions = 2\ndt = 0.01\nrestitution = 1e300\n".to_string(),
            "must be in [0, 1], got 1e300",
        ),
        (
            box_2d(false, "", &particle("-1e300")),
            "must be a finite number > 0, got -1e300",
        ),
    ];
    for (text, shown) in cases {
        let e = refused(&text).to_string();
        assert!(e.contains(shown), "{e}");
        assert!(e.len() < 250, "{e}");
    }
}
