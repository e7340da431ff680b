//! Reorderable passes: any rotation of the per-bounce cycle, and photons before camera in a
//! progressive pass, render the same bits as the default order; other orders are refused.

use crate::common;

use caustica::film::Image;
use caustica::scene::schedule::{Pass, ScheduleSettings, Stage};
use caustica::scene::{IntegratorKind, RunFile, load};

fn run_for(kind: IntegratorKind, schedule: ScheduleSettings) -> (caustica::scene::Scene, RunFile) {
    let (scene, mut run): (_, RunFile) = load(&common::data("cornell-spheres.gltf")).unwrap();
    run.render.integrator = kind;
    run.render.spp = 2;
    run.progressive.passes = 2;
    run.progressive.photons_per_pass = 5000;
    run.photons.photons = 5000;
    run.photons.caustic_photons = 5000;
    run.film.width = Some(24);
    run.film.height = Some(24);
    run.schedule = schedule;
    (scene, run)
}

fn render(kind: IntegratorKind, schedule: ScheduleSettings) -> Image {
    let (scene, run) = run_for(kind, schedule);
    common::render(scene, &run)
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn rotated_stage_orders_render_the_same_bits() {
    use Stage::*;
    for kind in [IntegratorKind::Pt, IntegratorKind::Pm, IntegratorKind::Sppm] {
        let default = bits(&render(kind, ScheduleSettings::default()));
        for order in [[Gather, Emit, Trace, Scatter, Shadow], [Scatter, Shadow, Gather, Emit, Trace]] {
            let schedule = ScheduleSettings { order: Some(order.to_vec()), ..Default::default() };
            assert!(
                bits(&render(kind, schedule)) == default,
                "{kind:?} with {order:?} differs from the default order"
            );
        }
    }
}

#[test]
fn photons_before_camera_renders_the_same_bits() {
    let default = bits(&render(IntegratorKind::Sppm, ScheduleSettings::default()));
    let schedule = ScheduleSettings {
        passes: Some(vec![Pass::Photons, Pass::Camera, Pass::Statistics]),
        ..Default::default()
    };
    assert!(bits(&render(IntegratorKind::Sppm, schedule)) == default);
}

// `sppm` without light sampling (photons carry direct light too) is held to `pt` with a derived bound
// in tests/environment.rs (`photon_mappers_see_the_same_environment_as_the_path_tracer`).

#[test]
fn a_run_file_with_an_invalid_order_is_refused_naming_the_dependency() {
    let path = std::path::Path::new("bad-order.toml");
    let text = "[schedule]\norder = [\"trace\", \"emit\", \"scatter\", \"shadow\", \"gather\"]\n";
    let message = RunFile::parse(text, path).unwrap_err().to_string();
    assert!(message.contains("bad-order.toml") && message.contains("after Gather"), "{message}");
}

#[test]
fn optional_systems_are_refused_where_the_integrator_cannot_take_them() {
    let refusal = |kind, schedule| {
        let (scene, run) = run_for(kind, schedule);
        caustica::Renderer::new(scene, &run).err().map(|e| e.to_string())
    };
    let no_caustics = ScheduleSettings { caustic_map: Some(false), ..Default::default() };
    let message = refusal(IntegratorKind::Pm, no_caustics).expect("pm without its caustic map is refused");
    assert!(message.contains("would lose caustics"), "{message}");
    let nee = ScheduleSettings { nee: Some(true), ..Default::default() };
    let message = refusal(IntegratorKind::Ppm, nee.clone()).expect("ppm with light sampling is refused");
    assert!(message.contains("contradicts ppm"), "{message}");
    assert!(refusal(IntegratorKind::Sppm, nee).is_none());
    let passes = ScheduleSettings {
        passes: Some(vec![Pass::Photons, Pass::Camera, Pass::Statistics]),
        ..Default::default()
    };
    let message = refusal(IntegratorKind::Pt, passes).expect("pt with a pass order is refused");
    assert!(message.contains("schedule.passes applies to ppm"), "{message}");
}
