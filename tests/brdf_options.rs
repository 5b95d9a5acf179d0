//! `roks brdf`'s options: each option that overrides a scene key gives
//! the run (and the tallies) of the scene with that key, and is refused
//! with the message of that key's check, naming the option.

use clap::FromArgMatches;
use roks::cli::Failure;
use roks::cli::args::{Cli, Command};
use roks::cli::brdf::BrdfArgs;
use roks::export::exporter::BrdfFormat;
use roks::scene::micro::MicroScene;
use roks::shard::Shard;
use roks::tally::{PolarTally, Symmetry};
use roks::transport::launch::Launch;

/// The options of `roks brdf ARGS` (no scene: the default scene).
fn args(args: &[&str]) -> BrdfArgs {
    let m = roks::cli::messages::command::<Cli>()
        .try_get_matches_from(["roks", "brdf"].iter().chain(args))
        .unwrap();
    match Cli::from_arg_matches(&m).unwrap().command {
        Command::Brdf(a) => a,
        other => panic!("{other:?}"),
    }
}

/// The message of the options' refusal.
fn refusal(a: &[&str]) -> String {
    match args(a).scene() {
        Err(Failure::Input(m)) => m,
        other => panic!("{a:?}: {other:?}"),
    }
}

/// The default scene with a Fresnel material (so that polarised
/// transport is on by default).
fn fresnel_text() -> String {
    roks::scene::micro::DEFAULT_SCENE.replace("reflectance = 0.8", "n = 1.5\nk = 0.1")
}

/// [`fresnel_text`] with `[section] key = value`.
fn with_key(section: &str, key: &str, value: toml::Value) -> MicroScene {
    let mut t: toml::Table = fresnel_text().parse().unwrap();
    t.entry(section)
        .or_insert_with(|| toml::Table::new().into())
        .as_table_mut()
        .unwrap()
        .insert(key.into(), value);
    let scene_file = roks::scene::SceneFile {
        file: "<default scene>".into(),
        dir: ".".into(),
    };
    MicroScene::from_str(&toml::to_string(&t).unwrap(), scene_file, "default".into()).unwrap()
}

/// Bits of a value through its JSON form (shortest round-trip floats:
/// distinct bits, distinct text).
fn bits<T: serde::Serialize>(x: &T) -> String {
    serde_json::to_string(x).unwrap()
}

/// Every option that overrides a scene key gives the run (and, traced,
/// the tallies) of the scene with that key, bit for bit.
#[test]
fn every_option_is_its_scene_key() {
    use toml::Value as V;
    let list = |xs: &[f64]| V::Array(xs.iter().map(|&x| V::Float(x)).collect());
    let mut grid = toml::Table::new();
    grid.insert("from".into(), V::Float(0.4));
    grid.insert("to".into(), V::Float(0.6));
    grid.insert("step".into(), V::Float(0.1));
    let cases: Vec<(Vec<&str>, &str, &str, V)> = vec![
        (
            vec!["--photons", "5000"],
            "light",
            "photons",
            V::Integer(5000),
        ),
        (vec!["--seed", "9"], "light", "seed", V::Integer(9)),
        (
            vec!["--theta", "0,45"],
            "light",
            "theta_deg",
            list(&[0.0, 45.0]),
        ),
        (vec!["--phi", "30"], "light", "phi_deg", V::Float(30.0)),
        (
            vec!["--phi", "0,90,45"],
            "light",
            "phi_deg",
            list(&[0.0, 90.0, 45.0]),
        ),
        (
            vec!["--wavelengths", "0.45,0.55"],
            "light",
            "wavelengths_um",
            list(&[0.45, 0.55]),
        ),
        (
            vec!["--wavelengths", "0.4:0.6:0.1"],
            "light",
            "wavelengths_um",
            V::Table(grid),
        ),
        (
            vec!["--launch", "lattice"],
            "light",
            "launch",
            V::String("lattice".into()),
        ),
        (
            vec!["--symmetry", "mirror"],
            "tally",
            "symmetry",
            V::String("mirror".into()),
        ),
        (
            vec!["--polarisation", "stokes"],
            "tally",
            "polarisation",
            V::String("stokes".into()),
        ),
        (
            vec!["--no-polarisation"],
            "transport",
            "polarisation",
            V::Boolean(false),
        ),
    ];
    let dir = std::env::temp_dir().join(format!("roks-options-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("fresnel.toml");
    std::fs::write(&file, fresnel_text()).unwrap();
    let path = file.to_str().unwrap();
    let plain = args(&[path]).scene().unwrap().run;
    assert!(plain.polarisation.transport);
    for (options, section, key, value) in cases {
        let by_option = args(&[&[path], &options[..]].concat()).scene().unwrap();
        let by_key = with_key(section, key, value);
        assert_eq!(bits(&by_option.run), bits(&by_key.run), "{options:?}");
        assert_ne!(
            bits(&by_option.run),
            bits(&plain),
            "{options:?} changes nothing"
        );
        // Traced (a few photons at one angle), the same tallies.
        let trace = |scene: &MicroScene| {
            let mut run = scene.brdf_run();
            run.photons = 64;
            run.theta_deg.truncate(1);
            run.bands = 4;
            run.trace_whole(&scene.surface, &|_| {})
        };
        let (a, b) = (trace(&by_option), trace(&by_key));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(bits(&x.tallies), bits(&y.tallies), "{options:?}");
        }
    }
    // No option: the scene's own run; formats each once, in the order
    // given, names in any case; the shard's block.
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(
        bits(&args(&[]).scene().unwrap().run),
        bits(&MicroScene::default_scene().run)
    );
    assert_eq!(
        args(&["--export", "MERL,zemax"]).export,
        [BrdfFormat::Merl, BrdfFormat::Zemax]
    );
    assert_eq!(
        args(&["--shard", "1/4"]).shard,
        Some(Shard { index: 1, count: 4 })
    );
    let stokes = args(&["--polarisation", "stokes"]).scene().unwrap().run;
    assert_eq!(stokes.polarisation.tally, PolarTally::Stokes);
    assert!(stokes.polarisation.transport);
    let mirror = args(&["--symmetry", "mirror", "--launch", "lattice"])
        .scene()
        .unwrap()
        .run;
    assert_eq!(
        (mirror.symmetry, mirror.launch),
        (Symmetry::Mirror, Launch::Lattice)
    );
}

#[test]
fn options_are_checked_as_the_scene_keys_they_override() {
    assert_eq!(
        refusal(&["--theta", "95"]),
        "--theta: angle 1: must be in [0, 90), got 95"
    );
    assert_eq!(
        refusal(&["--theta", "10,20,10"]),
        "--theta: angle 3: 10 is given twice (each incidence angle once: a BRDF table holds one block per angle)"
    );
    assert_eq!(
        refusal(&["--phi", "0,360"]),
        "--phi: azimuth 2: must be in [0, 360), got 360"
    );
    assert_eq!(
        refusal(&["--phi", "90,0,90"]),
        "--phi: azimuth 3: 90 is given twice (each light azimuth once: a BRDF table holds one block per incidence and azimuth)"
    );
    assert_eq!(
        refusal(&["--photons", "9007199254740993"]),
        "--photons: must be at most 2^53 = 9007199254740992 (the f64 tallies cannot count more exactly), got 9007199254740993"
    );
    assert_eq!(
        refusal(&["--photons", "100", "--launch", "lattice"]),
        "--photons: must be a multiple of 16 with launch = \"lattice\", got 100"
    );
    assert_eq!(
        refusal(&["--no-polarisation", "--polarisation", "mueller"]),
        "--no-polarisation: `mueller` needs polarised transport, but [transport] polarisation = false"
    );
    assert_eq!(
        refusal(&["--wavelengths", "0.5,0.4"]),
        "--wavelengths: wavelength 2: 0.4 um is not greater than the previous 0.5 um (wavelengths strictly increasing)"
    );
    assert_eq!(
        refusal(&["--wavelengths", "0.6:0.4:0.1"]),
        "--wavelengths: needs finite from <= to, got 0.6 and 0.4"
    );
}
