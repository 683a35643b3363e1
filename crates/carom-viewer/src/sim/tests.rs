use super::*;
use carom_engine::BroadPhaseKind;

fn wait_for(sim: &Sim, what: &str, ok: impl Fn(&Shared) -> bool) {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) {
        {
            let mut s = sim.lock();
            s.drawn = s.seq; // play the UI's part
            if ok(&s) {
                return;
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("timed out waiting for {what}: error {:?}", sim.lock().error);
}

#[test]
fn every_control_works_and_bad_values_are_errors() {
    let text = carom_scene::preset("lecture_100_k05").unwrap().to_string();
    let sim = Sim::start(text.clone(), "preset:lecture_100_k05".into(), false);
    wait_for(&sim, "the first snapshot", |s| {
        s.snapshot.radii.len() == 100
    });
    assert_eq!(sim.lock().snapshot.steps, 0);

    sim.send(Command::Step);
    wait_for(&sim, "one step", |s| s.snapshot.steps == 1);

    sim.send(Command::StepsPerFrame(5));
    sim.send(Command::Play(true));
    wait_for(&sim, "running", |s| {
        s.snapshot.steps >= 20 && s.snapshot.ms_per_step > 0.0
    });
    sim.send(Command::Play(false));

    let good = Params {
        restitution: 0.3,
        gravity: [1.0, -2.0, 0.0],
        dt: 0.002,
    };
    sim.send(Command::Params(good));
    wait_for(&sim, "new parameters", |s| {
        s.snapshot.params == Some(good) && s.error.is_none()
    });

    let bad = Params {
        restitution: 7.0,
        gravity: [f64::NAN, 0.0, 0.0],
        dt: 0.0,
    };
    sim.send(Command::Params(bad));
    wait_for(&sim, "the refusal", |s| s.error.is_some());
    assert_eq!(
        sim.lock().snapshot.params,
        Some(good),
        "refused values change nothing"
    );

    for (kind, cells) in [
        (BroadPhaseKind::Brute, None),
        (BroadPhaseKind::Hash, None),
        (BroadPhaseKind::Grid, Some(vec![7, 9])),
    ] {
        let choice = BroadPhaseChoice { kind, cells };
        sim.send(Command::BroadPhase(choice.clone()));
        wait_for(&sim, "the broad phase", |s| {
            s.snapshot.broad_phase_choice.as_ref() == Some(&choice)
        });
    }
    // a grid the engine refuses: an error, the world runs on
    let wrong = BroadPhaseChoice {
        kind: BroadPhaseKind::Grid,
        cells: Some(vec![3]),
    };
    sim.send(Command::BroadPhase(wrong));
    wait_for(&sim, "the grid refusal", |s| {
        s.error.as_deref().is_some_and(|e| e.contains("cell"))
    });

    sim.send(Command::Reset);
    wait_for(&sim, "the reset", |s| {
        s.snapshot.steps == 0 && s.snapshot.generation == 2
    });
    // the reset keeps the parameters chosen in the panel
    assert_eq!(sim.lock().snapshot.params, Some(good));

    sim.send(Command::Load("dimensions = 7".into(), "test".into()));
    wait_for(&sim, "the bad scene's error", |s| {
        s.error.as_deref().is_some_and(|e| e.contains("dimensions"))
    });
    assert_eq!(
        sim.lock().snapshot.radii.len(),
        100,
        "a bad scene leaves the old one running"
    );

    let three = carom_scene::preset("newton_cradle_3d").unwrap().to_string();
    sim.send(Command::Load(three, "preset:newton_cradle_3d".into()));
    wait_for(&sim, "the 3D scene", |s| s.snapshot.dims == 3);
    drop(sim); // joins the thread: no hang
}
