//! The pinhole camera both renderers share, framed on a shape's bounding box.

use crate::error::{Error, Result};
use crate::geometry::{Aabb, DVec3};

/// A perspective pinhole camera looking at the centre of a box.
///
/// The vertical axis is +y (the convention of the OBJ and PLY models the paper uses). An
/// azimuth of 0° and elevation of 0° look from +z towards -z; the azimuth turns the eye about
/// +y towards +x, the elevation raises it towards +y. Pixel `(x, y)` counts columns from the
/// left and rows from the top, and its ray passes through the pixel's centre, so the ray
/// marcher and the rasterizer cover exactly the same pixels for the same surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half_x: f64,
    tan_half_y: f64,
    width: usize,
    height: usize,
}

impl Camera {
    /// The vertical field of view, in degrees: narrow, so the picture is close to the
    /// orthographic views of the paper's figures without losing depth cues.
    pub const FIELD_OF_VIEW_DEG: f64 = 20.0;

    /// The largest image side accepted (a picture of 8192 x 8192 takes 256 MB).
    pub const MAX_SIDE: usize = 8192;

    /// The default view of every picture: azimuth and elevation in degrees, a three-quarter
    /// view from the front right and a little above.
    pub const DEFAULT_VIEW: [f64; 2] = [35.0, 20.0];

    /// The default picture size in pixels, width and height.
    pub const DEFAULT_SIZE: [usize; 2] = [800, 600];

    /// The fraction of the frame the box may fill along its tighter axis.
    const FILL: f64 = 0.92;

    /// A camera looking at the centre of `bounds` from the given direction, at the distance
    /// where the whole box, seen from there, fills about 92% of a `width` x `height` frame.
    ///
    /// Angles are in degrees. Fails when the box or an angle is not finite, or when a side of
    /// the image is 0 or above [`Camera::MAX_SIDE`]. A box of zero size is framed as if it had a
    /// tiny extent.
    pub fn framing(
        bounds: &Aabb,
        azimuth_deg: f64,
        elevation_deg: f64,
        width: usize,
        height: usize,
    ) -> Result<Camera> {
        check_size(width, height)?;
        if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.min.cmpgt(bounds.max).any()
        {
            return Err(Error::invalid("camera", format!("cannot frame the box {bounds:?}")));
        }
        if !(azimuth_deg.is_finite() && elevation_deg.is_finite()) {
            return Err(Error::invalid(
                "camera",
                format!("the view angles must be finite, not {azimuth_deg} and {elevation_deg}"),
            ));
        }
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let towards_eye = DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
        let forward = -towards_eye;
        let up_hint =
            if forward.y.abs() > 0.999 { DVec3::new(0.0, 0.0, -forward.y) } else { DVec3::Y };
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        let tan_half_y = (Self::FIELD_OF_VIEW_DEG.to_radians() * 0.5).tan();
        let tan_half_x = tan_half_y * width as f64 / height as f64;
        let center = bounds.center();
        let radius = (0.5 * bounds.diagonal()).max(1e-12 * (1.0 + center.abs().max_element()));
        // The eye sits on the far side of `distance` from the centre: every corner must project
        // inside the frame, and the eye must stay outside the box's bounding sphere.
        let mut distance = 1.01 * radius;
        for i in 0..8 {
            let corner = DVec3::new(
                if i & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if i & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if i & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            let v = corner - center;
            let depth = v.dot(forward);
            distance = distance
                .max(v.dot(right).abs() / (tan_half_x * Self::FILL) - depth)
                .max(v.dot(up).abs() / (tan_half_y * Self::FILL) - depth);
        }
        Ok(Camera {
            eye: center - distance * forward,
            forward,
            right,
            up,
            tan_half_x,
            tan_half_y,
            width,
            height,
        })
    }

    /// The image width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The image height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The eye's position.
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// The unit viewing direction.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// The unit direction of the ray through the centre of pixel `(x, y)`, which starts at
    /// [`Camera::eye`].
    pub fn ray(&self, x: usize, y: usize) -> DVec3 {
        let sx = ((x as f64 + 0.5) / self.width as f64 * 2.0 - 1.0) * self.tan_half_x;
        let sy = (1.0 - (y as f64 + 0.5) / self.height as f64 * 2.0) * self.tan_half_y;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }

    /// Where `p` lands on the image as continuous pixel coordinates (pixel `(x, y)` has its
    /// centre at `(x + 0.5, y + 0.5)`), and its depth along the viewing direction. The depth is
    /// not positive for a point level with or behind the eye.
    pub fn project(&self, p: DVec3) -> (f64, f64, f64) {
        let v = p - self.eye;
        let depth = v.dot(self.forward);
        let sx = v.dot(self.right) / (depth * self.tan_half_x);
        let sy = v.dot(self.up) / (depth * self.tan_half_y);
        ((sx + 1.0) * 0.5 * self.width as f64, (1.0 - sy) * 0.5 * self.height as f64, depth)
    }

    /// The direction towards the key light: above and to the left of the eye, so shapes are
    /// lit from the front the way the paper's figures are.
    pub fn light(&self) -> DVec3 {
        (-self.forward + 0.6 * self.up - 0.45 * self.right).normalize()
    }

    /// The tangent of half the vertical field of view.
    pub fn tan_half_fov_y(&self) -> f64 {
        self.tan_half_y
    }
}

fn check_size(width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 || width > Camera::MAX_SIDE || height > Camera::MAX_SIDE {
        return Err(Error::invalid(
            "camera",
            format!(
                "an image of {width} x {height} pixels is outside the accepted 1..={} per side",
                Camera::MAX_SIDE
            ),
        ));
    }
    Ok(())
}
