//! Helpers shared by the physics-validation integration tests: build a micro
//! scene from TOML text and trace it with the settings the scene asks for.
#![allow(dead_code)]

use roks::scene::Source;
use roks::scene::micro::MicroScene;
use roks::transport::brdf::{BrdfRun, IncidenceResult};
use roks::transport::micro::Controls;

/// Parse and build a micro scene from TOML text (panics with the scene error).
#[must_use]
pub fn scene(name: &str, toml: &str) -> MicroScene {
    let source = Source {
        file: format!("{name}.toml"),
        dir: ".".into(),
    };
    MicroScene::from_str(toml, source, name.into()).unwrap_or_else(|e| panic!("scene {name}: {e}"))
}

/// The run described by the scene's `[light]`, `[tally]` and `[transport]`.
#[must_use]
pub fn brdf_run(scene: &MicroScene) -> BrdfRun {
    BrdfRun {
        theta_deg: scene.light.theta_deg.clone(),
        phi_deg: scene.light.phi_deg,
        photons: scene.light.photons,
        first_photon: 0,
        seed: scene.light.seed,
        bands: scene.tally.bands,
        inplane_step_deg: scene.tally.inplane_step_deg,
        inplane_width_deg: scene.tally.inplane_width_deg,
        controls: Controls {
            max_bounces: scene.transport.max_bounces,
            roulette_weight: scene.transport.roulette_weight,
            ..Controls::default()
        },
    }
}

/// Trace every incidence angle of the scene.
#[must_use]
pub fn run(scene: &MicroScene) -> Vec<IncidenceResult> {
    brdf_run(scene).run(&scene.surface, &|_| {})
}

/// Lost weight broken down, for messages.
#[must_use]
pub fn losses(r: &IncidenceResult) -> String {
    let t = &r.tallies;
    format!(
        "walls {}, cap {} ({} histories), numeric {} ({} histories)",
        t.lost_walls, t.lost_cap, t.capped_histories, t.lost_numeric, t.numeric_histories
    )
}
