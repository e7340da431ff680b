//! Writes scenes/sky.exr: a procedural clear-sky environment map for scenes/environment.toml.
//!
//! Equirectangular, 512 × 256, in Caustica's map convention (row 0 at the zenith, the centre column
//! looking along +Z). A blue sky brightening to a hazy horizon (a Preetham-like gradient, not a
//! physical sky model), a sun 38° high in the −X/−Z quadrant of angular radius 1.5° whose disc
//! delivers about three times the sky's irradiance on a horizontal surface (a clear noon is 4–8×),
//! and a dim ground. Deterministic. Run: `cargo run --release --example make_sky`.

use caustica::film::Image;
use caustica::film::output::write_image;
use caustica::lights::environment::uv_to_direction;
use glam::{Vec2, Vec3};

const WIDTH: u32 = 512;
const HEIGHT: u32 = 256;

fn main() {
    let sun = {
        let (elevation, azimuth) = (38f32.to_radians(), (-135f32).to_radians());
        Vec3::new(elevation.cos() * azimuth.sin(), elevation.sin(), elevation.cos() * azimuth.cos())
    };
    let sun_cos = 1.5f32.to_radians().cos();
    let sun_radiance = Vec3::new(1.0, 0.92, 0.8) * 1500.0;
    let pixels = (0..WIDTH * HEIGHT)
        .map(|i| {
            let uv = Vec2::new(
                ((i % WIDTH) as f32 + 0.5) / WIDTH as f32,
                ((i / WIDTH) as f32 + 0.5) / HEIGHT as f32,
            );
            let d = uv_to_direction(uv);
            if d.dot(sun) >= sun_cos {
                return sun_radiance;
            }
            if d.y < 0.0 {
                // Ground seen below the horizon: dim, warm, darker straight down.
                return Vec3::new(0.09, 0.08, 0.06) * (1.0 + d.y * 0.5);
            }
            let zenith = Vec3::new(0.12, 0.25, 0.65);
            let horizon = Vec3::new(0.75, 0.8, 0.9);
            let haze = (1.0 - d.y).powi(4);
            // Brighter towards the sun (forward scattering).
            let glow = 0.6 * d.dot(sun).max(0.0).powi(8);
            zenith.lerp(horizon, haze) * (1.0 + glow)
        })
        .collect();
    let image = Image { width: WIDTH, height: HEIGHT, pixels };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sky.exr");
    write_image(&image, &path, 0.0).expect("write scenes/sky.exr");
    println!("wrote {}", path.display());
}
