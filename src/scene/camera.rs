//! The pinhole camera and its ray differentials.

use crate::geometry::differential::RayDifferential;
use crate::geometry::lanes::{add, dot, scale, splat3, sub, Lane, V3};
use glam::DVec3;

/// A pinhole camera. Pixel `(0, 0)` is the top-left; pixel `(i, j)` covers
/// `[i, i+1] x [j, j+1]` in continuous pixel coordinates `(x, y)`, `y` growing downwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Unit view direction.
    pub forward: DVec3,
    /// Unit right vector of the image plane.
    pub right: DVec3,
    /// Unit up vector of the image plane.
    pub up: DVec3,
    /// `tan(fov_y / 2)`.
    pub tan_half_fov: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A camera at `eye` looking at `look_at`, `up` giving the vertical, with a vertical field
    /// of view of `fov_y_degrees`. `None` when the view direction is zero or parallel to `up`.
    pub fn look_at(
        eye: DVec3,
        look_at: DVec3,
        up: DVec3,
        fov_y_degrees: f64,
        width: u32,
        height: u32,
    ) -> Option<Self> {
        let forward = (look_at - eye).try_normalize()?;
        // Scaled to its largest component first: `up = [0, 1e300, 0]` (or 1e-300) is a fine
        // direction whose cross product with `forward` over- or underflows.
        let up = up / up.abs().max_element();
        let right = forward.cross(up).try_normalize()?;
        if forward.cross(up).length() < 1e-9 * up.length() {
            return None;
        }
        let up = right.cross(forward);
        Some(Camera {
            eye,
            forward,
            right,
            up,
            tan_half_fov: (fov_y_degrees.to_radians() * 0.5).tan(),
            width,
            height,
        })
    }

    /// The same camera rendering `width x height` pixels (same vertical field of view).
    pub fn with_resolution(&self, width: u32, height: u32) -> Self {
        Camera {
            width,
            height,
            ..self.clone()
        }
    }

    fn aspect(&self) -> f64 {
        self.width as f64 / self.height as f64
    }

    /// Un-normalised direction `d = V + sx R + sy U` through continuous pixel coordinates.
    fn direction(&self, x: f64, y: f64) -> DVec3 {
        self.toward(self.screen_x(x), self.screen_y(y))
    }

    /// `V + sx R + sy U`: [`Camera::direction`] from screen coordinates.
    fn toward(&self, sx: f64, sy: f64) -> DVec3 {
        DVec3::from_array(self.toward_lanes(sx, sy))
    }

    /// [`Camera::toward`] in any lanes.
    #[inline(always)]
    fn toward_lanes<T: Lane>(&self, sx: T, sy: T) -> V3<T> {
        let (forward, right, up) = (splat3(self.forward), splat3(self.right), splat3(self.up));
        add(add(forward, scale(right, sx)), scale(up, sy))
    }

    /// `sx` of [`Camera::direction`] at pixel column `x`.
    fn screen_x(&self, x: f64) -> f64 {
        (2.0 * x / self.width as f64 - 1.0) * self.tan_half_fov * self.aspect()
    }

    /// `sy` of [`Camera::direction`] at pixel row `y`.
    fn screen_y(&self, y: f64) -> f64 {
        (1.0 - 2.0 * y / self.height as f64) * self.tan_half_fov
    }

    /// The ray through continuous pixel coordinates `(x, y)`, with differentials with respect to
    /// `x` and `y` scaled by `spacing` (1 for a ray per pixel; `1/N` for an N x N grid), so that
    /// its footprint is the parallelogram `P +- dP/du / 2 +- dP/dv / 2` of one (sub-)pixel.
    ///
    /// `dD/dx = ((d.d) dd/dx - (d . dd/dx) d) / (d.d)^(3/2)`, `dP = 0`.
    pub fn ray(&self, x: f64, y: f64, spacing: f64) -> RayDifferential {
        let d = self.direction(x, y);
        let dd_dx = self.right * (2.0 * self.tan_half_fov * self.aspect() / self.width as f64);
        let dd_dy = self.up * (-2.0 * self.tan_half_fov / self.height as f64);
        let dd2 = d.dot(d);
        let len = dd2.sqrt();
        // (d.d)^(3/2) as a product: libm's `pow` here was 2-3% of a render's profile.
        let scale = spacing / (dd2 * len);
        let norm = |dd: DVec3| (dd * dd2 - d * d.dot(dd)) * scale;
        RayDifferential {
            p: self.eye,
            d: d / len,
            dp: [DVec3::ZERO; 2],
            dd: [norm(dd_dx), norm(dd_dy)],
        }
    }

    /// The rectangle `[x0, x1] x [y0, y1]` of the image (continuous pixel coordinates) seen on
    /// the plane through `point` with normal `normal`: where the rays through its corners meet
    /// the plane, in the order `(x0, y0), (x1, y0), (x1, y1), (x0, y1)`. `None` where a corner's
    /// ray runs parallel to the plane or meets it behind the eye (the plane's horizon crosses
    /// the rectangle). Rectangles sharing corners give quadrilaterals sharing corners: they tile
    /// the plane as the pixels tile the image.
    pub fn rectangle_on_plane(
        &self,
        cell: [f64; 4],
        point: DVec3,
        normal: DVec3,
    ) -> Option<[DVec3; 4]> {
        let (sx, sy) = self.screen_rectangle(cell);
        let (corners, t) = self.corners_on_plane(sx, sy, point.to_array(), normal.to_array());
        t.iter()
            .all(|&t| t > 0.0 && t.is_finite())
            .then(|| corners.map(DVec3::from_array))
    }

    /// The screen coordinates of the rectangle `[x0, x1] x [y0, y1]`'s two columns and two rows
    /// (as `direction` computes them: a corner shared with a neighbour comes out the same).
    pub fn screen_rectangle(&self, [x0, y0, x1, y1]: [f64; 4]) -> ([f64; 2], [f64; 2]) {
        (
            [self.screen_x(x0), self.screen_x(x1)],
            [self.screen_y(y0), self.screen_y(y1)],
        )
    }

    /// [`Camera::rectangle_on_plane`] in any lanes, from the rectangle's screen coordinates
    /// ([`Camera::screen_rectangle`]): the four corners and each corner's ray parameter `t`
    /// (a corner stands where `t > 0` and finite; elsewhere its ray runs parallel to the plane
    /// or meets it behind the eye).
    #[inline(always)]
    pub fn corners_on_plane<T: Lane>(
        &self,
        sx: [T; 2],
        sy: [T; 2],
        point: V3<T>,
        normal: V3<T>,
    ) -> ([V3<T>; 4], [T; 4]) {
        let eye = splat3(self.eye);
        let depth = dot(sub(point, eye), normal);
        let mut corners = [[T::splat(0.0); 3]; 4];
        let mut t = [T::splat(0.0); 4];
        for (k, (i, j)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
            let d = self.toward_lanes(sx[i], sy[j]);
            t[k] = depth / dot(d, normal);
            corners[k] = add(eye, scale(d, t[k]));
        }
        (corners, t)
    }

    /// Continuous pixel coordinates where `point` projects, or `None` behind the camera.
    pub fn project(&self, point: DVec3) -> Option<(f64, f64)> {
        let v = point - self.eye;
        let z = v.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = v.dot(self.right) / z;
        let sy = v.dot(self.up) / z;
        let x = (sx / (self.tan_half_fov * self.aspect()) + 1.0) * 0.5 * self.width as f64;
        let y = (1.0 - sy / self.tan_half_fov) * 0.5 * self.height as f64;
        Some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(
            DVec3::new(2.5, 4.5, 7.0),
            DVec3::new(0.4, 0.4, 0.3),
            DVec3::Y,
            40.0,
            640,
            480,
        )
        .unwrap()
    }

    #[test]
    fn project_inverts_ray_and_centre_looks_forward() {
        let c = camera();
        let r = c.ray(320.0, 240.0, 1.0);
        assert!((r.d - c.forward).length() < 1e-12);
        let (x, y) = c.project(c.eye + c.ray(12.25, 400.5, 1.0).d * 3.0).unwrap();
        assert!((x - 12.25).abs() < 1e-9 && (y - 400.5).abs() < 1e-9);
        // The top edge is at half the field of view above the axis.
        let top = c.ray(320.0, 0.0, 1.0).d;
        assert!((top.dot(c.forward).acos().to_degrees() - 20.0).abs() < 1e-9);
    }

    #[test]
    fn direction_differentials_match_finite_differences() {
        let c = camera();
        let (x, y, h) = (100.3, 71.9, 1e-5);
        let r = c.ray(x, y, 1.0);
        let fd_x = (c.ray(x + h, y, 1.0).d - c.ray(x - h, y, 1.0).d) / (2.0 * h);
        let fd_y = (c.ray(x, y + h, 1.0).d - c.ray(x, y - h, 1.0).d) / (2.0 * h);
        assert!((r.dd[0] - fd_x).length() < 1e-8 * fd_x.length().max(1e-3) * 1e3);
        assert!((r.dd[1] - fd_y).length() < 1e-8 * fd_y.length().max(1e-3) * 1e3);
    }

    #[test]
    fn a_new_resolution_keeps_the_view() {
        let c = camera();
        let small = c.with_resolution(80, 60);
        // Same relative image position, same direction.
        let (a, b) = (c.ray(100.0, 30.0, 1.0).d, small.ray(12.5, 3.75, 1.0).d);
        assert!((a - b).length() < 1e-12);
        assert_eq!((small.width, small.height), (80, 60));
    }

    #[test]
    fn up_parallel_to_view_is_rejected() {
        assert!(Camera::look_at(DVec3::ZERO, DVec3::Y, DVec3::Y, 40.0, 4, 4).is_none());
    }
}
