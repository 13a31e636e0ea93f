//! Colours and light: the material, the normal map, the red-to-green scalar map and the
//! shading every renderer applies to a surface point.

use crate::geometry::DVec3;

use super::camera::Camera;

/// How a surface is coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Coloring {
    /// A light, matte-ish material lit by one key light from the upper left of the eye.
    #[default]
    Plain,
    /// The outward unit normal `n` (in world axes) as the colour `(n + 1) / 2`, unlit.
    Normals,
}

/// The plain material's colour.
const MATERIAL: DVec3 = DVec3::new(0.86, 0.84, 0.80);

/// The scalar map's colours at 0, 1/2 and 1: red where small, yellow, green where large
/// (the paper's figure 3).
const RED: DVec3 = DVec3::new(0.86, 0.12, 0.08);
const YELLOW: DVec3 = DVec3::new(0.95, 0.85, 0.15);
const GREEN: DVec3 = DVec3::new(0.12, 0.70, 0.20);

/// The colour used for a scalar that is not a number.
const NO_VALUE: DVec3 = DVec3::new(0.5, 0.5, 0.5);

/// The colour of `value` on the scalar map over `range`: red at `range.0` and below, green at
/// `range.1` and above, through yellow; grey for a value that is not finite.
pub(crate) fn scalar_color(value: f32, range: (f32, f32)) -> DVec3 {
    if !value.is_finite() {
        return NO_VALUE;
    }
    let t = ((value - range.0) / (range.1 - range.0)).clamp(0.0, 1.0) as f64;
    if t < 0.5 { RED.lerp(YELLOW, 2.0 * t) } else { YELLOW.lerp(GREEN, 2.0 * t - 1.0) }
}

/// What a surface point looks like.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Surface {
    /// Coloured by a [`Coloring`].
    Colored(Coloring),
    /// The given base colour, lit.
    Base(DVec3),
}

/// The opaque pixel for a surface point with outward unit `normal` seen along the unit ray
/// direction `ray`. The normal is turned towards the eye first, so both sides of an open or
/// inconsistently oriented mesh are lit alike.
pub(crate) fn shade(surface: Surface, normal: DVec3, ray: DVec3, camera: &Camera) -> [u8; 4] {
    let n = if normal.dot(ray) > 0.0 { -normal } else { normal };
    let color = match surface {
        Surface::Colored(Coloring::Normals) => (n + DVec3::ONE) * 0.5,
        Surface::Colored(Coloring::Plain) => lit(MATERIAL, n, ray, camera.light()),
        Surface::Base(base) => lit(base, n, ray, camera.light()),
    };
    let byte = |c: f64| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
    [byte(color.x), byte(color.y), byte(color.z), 255]
}

/// Ambient plus Lambert diffuse plus a soft Blinn-Phong highlight.
fn lit(base: DVec3, n: DVec3, ray: DVec3, light: DVec3) -> DVec3 {
    let diffuse = n.dot(light).max(0.0);
    let half = (light - ray).normalize_or_zero();
    let specular = n.dot(half).max(0.0).powi(40);
    base * (0.22 + 0.78 * diffuse) + DVec3::splat(0.18 * specular)
}

/// The outward unit normal of a field at a point from its gradient (which points inside, the
/// inside being positive), or the reverse ray direction where the gradient vanishes.
pub(crate) fn field_normal(gradient: DVec3, ray: DVec3) -> DVec3 {
    let n = -gradient.normalize_or_zero();
    if n == DVec3::ZERO || !n.is_finite() { -ray } else { n }
}
