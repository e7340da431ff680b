//! Punctual lights (KHR_lights_punctual): points, spots and suns, from a glTF node or a run file's
//! `[[light]]` table, in the extension's photometric units.

use glam::Vec3;
use serde::Deserialize;
use std::f32::consts::FRAC_PI_2;

/// Luminous efficacy the extension converts with: 683 lm/W, so a point light of `intensity` candela
/// has a radiant intensity of `color × intensity / 683` W/sr, and a sun of `intensity` lux an
/// irradiance of `color × intensity / 683` W/m².
pub const LUMENS_PER_WATT: f32 = 683.0;

/// The kind of a punctual light, with a spot's cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    /// Emits equally in every direction from a point.
    Point,
    /// A point emitting inside a cone around its direction, full inside `inner_cone`, falling
    /// smoothly to nothing at `outer_cone` (half-angles, radians).
    Spot {
        /// Half-angle where the falloff starts.
        inner_cone: f32,
        /// Half-angle where it reaches zero.
        outer_cone: f32,
    },
    /// Parallel light from infinitely far away (the extension's "directional").
    Sun,
}

/// A punctual light in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLightDesc {
    /// Names the light in messages: `node 'lamp' (#3) light 'key' (#0)`, or `light[2]` of a run file.
    pub name: String,
    /// Which kind.
    pub kind: PunctualKind,
    /// Where it is (unused by a sun).
    pub position: Vec3,
    /// Unit direction the light travels along (a spot's axis, a sun's rays; unused by a point).
    pub direction: Vec3,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Candela (point, spot) or lux (sun).
    pub intensity: f32,
}

impl PunctualLightDesc {
    /// Radiant intensity in W/sr (point, spot) or irradiance in W/m² (sun), per channel.
    pub fn radiometric(&self) -> Vec3 {
        self.color * (self.intensity / LUMENS_PER_WATT)
    }

    /// What is wrong with this light, if anything: values a renderer cannot use.
    pub fn problem(&self) -> Option<String> {
        if !(self.color.is_finite() && self.color.min_element() >= 0.0) {
            return Some(format!("color is {}, must be finite and >= 0", self.color));
        }
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return Some(format!("intensity is {}, must be finite and >= 0", self.intensity));
        }
        if !self.position.is_finite() {
            return Some(format!("position is {}, not finite", self.position));
        }
        if self.kind != PunctualKind::Point && !(self.direction.is_finite() && self.direction.length() > 0.5)
        {
            return Some(format!("direction is {}, not a direction", self.direction));
        }
        if let PunctualKind::Spot { inner_cone, outer_cone } = self.kind
            && !(inner_cone >= 0.0 && inner_cone < outer_cone && outer_cone <= FRAC_PI_2)
        {
            return Some(format!(
                "cone angles inner {inner_cone} and outer {outer_cone} rad must satisfy 0 <= inner < outer <= π/2"
            ));
        }
        None
    }
}

/// A run file's `[[light]]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Name for messages.
    #[serde(default)]
    pub name: Option<String>,
    /// `point`, `spot` or `sun`.
    #[serde(rename = "type")]
    pub kind: LightSpecKind,
    /// Position (point, spot).
    #[serde(default)]
    pub position: [f32; 3],
    /// Direction the light travels (spot, sun); or give `target`.
    #[serde(default)]
    pub direction: Option<[f32; 3]>,
    /// A point the spot or sun shines towards (instead of `direction`; a sun's rays are parallel
    /// to `target − position`).
    #[serde(default)]
    pub target: Option<[f32; 3]>,
    /// Linear RGB colour.
    #[serde(default = "white")]
    pub color: [f32; 3],
    /// Candela (point, spot) or lux (sun).
    pub intensity: f32,
    /// Spot: half-angle where the falloff starts, degrees.
    #[serde(default)]
    pub inner_cone_degrees: f32,
    /// Spot: half-angle where the light ends, degrees.
    #[serde(default = "default_outer_cone")]
    pub outer_cone_degrees: f32,
}

/// The kinds a `[[light]]` may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSpecKind {
    /// A point light.
    Point,
    /// A spot light.
    Spot,
    /// A directional light.
    Sun,
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// The extension's default outer cone, π/4.
fn default_outer_cone() -> f32 {
    45.0
}

impl LightSpec {
    /// The light this table describes; `index` names it when it has no name.
    pub fn to_desc(&self, index: usize) -> Result<PunctualLightDesc, String> {
        let name = self.name.clone().map_or_else(|| format!("light[{index}]"), |n| format!("light '{n}'"));
        let position = Vec3::from(self.position);
        let direction = match (self.kind, self.direction, self.target) {
            (LightSpecKind::Point, ..) => Vec3::NEG_Z,
            (_, Some(_), Some(_)) => return Err(format!("{name}: give direction or target, not both")),
            (_, Some(d), None) => Vec3::from(d).normalize_or_zero(),
            (_, None, Some(t)) => (Vec3::from(t) - position).normalize_or_zero(),
            (_, None, None) => return Err(format!("{name}: a spot or sun needs a direction or a target")),
        };
        let kind = match self.kind {
            LightSpecKind::Point => PunctualKind::Point,
            LightSpecKind::Sun => PunctualKind::Sun,
            LightSpecKind::Spot => PunctualKind::Spot {
                inner_cone: self.inner_cone_degrees.to_radians(),
                outer_cone: self.outer_cone_degrees.to_radians(),
            },
        };
        let desc = PunctualLightDesc {
            name,
            kind,
            position,
            direction,
            color: Vec3::from(self.color),
            intensity: self.intensity,
        };
        match desc.problem() {
            Some(problem) => Err(format!("{}: {problem}", desc.name)),
            None => Ok(desc),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> LightSpec {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn a_spot_aimed_at_a_target_points_there_in_radians() {
        let desc = spec("type = 'spot'\nposition = [0, 2, 0]\ntarget = [0, 0, 0]\nintensity = 683\nouter_cone_degrees = 30")
            .to_desc(0)
            .unwrap();
        assert_eq!(desc.direction, Vec3::NEG_Y);
        assert_eq!(desc.kind, PunctualKind::Spot { inner_cone: 0.0, outer_cone: 30f32.to_radians() });
        assert_eq!(desc.radiometric(), Vec3::ONE);
    }

    #[test]
    fn bad_lights_are_refused_naming_the_light_and_the_problem() {
        for (text, needle) in [
            ("type = 'sun'\nintensity = 1", "needs a direction or a target"),
            ("type = 'sun'\nintensity = 1\ndirection = [0, 0, 0]", "not a direction"),
            ("type = 'point'\nintensity = -1", "intensity is -1"),
            ("type = 'point'\nintensity = nan", "intensity is NaN"),
            ("type = 'point'\nintensity = 1\ncolor = [1, -1, 0]", "color"),
            ("type = 'spot'\nintensity = 1\ndirection = [0, -1, 0]\nouter_cone_degrees = 120", "π/2"),
            ("type = 'spot'\nintensity = 1\ndirection = [0, -1, 0]\ninner_cone_degrees = 50", "inner"),
        ] {
            let error = spec(text).to_desc(3).unwrap_err();
            assert!(error.starts_with("light[3]") && error.contains(needle), "{text}: {error}");
        }
    }
}
