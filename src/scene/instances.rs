//! Instances: one mesh file placed many times, each with its own transform and material. The
//! mesh is loaded once and shared (one copy in memory, one BVH in Embree); memory stays flat in
//! the number of instances.

use super::descriptions::maybe_three;
use glam::{DAffine3, DMat3, DQuat, DVec3, EulerRot};
use serde::Deserialize;

/// The smallest and largest magnitude of an instance's scale factors: a million times smaller
/// or larger than the mesh file (micrometres to metres and back) covers any modelling unit.
pub const MIN_SCALE: f64 = 1e-6;
/// See [`MIN_SCALE`].
pub const MAX_SCALE: f64 = 1e6;

/// `scale = 2.0` (uniform) or `scale = [sx, sy, sz]` (per axis).
#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(untagged, expecting = "a number or three numbers [sx, sy, sz]")]
pub(super) enum Scale {
    Uniform(f64),
    Axes([f64; 3]),
}

/// An instance as the scene file writes it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct InstanceDesc {
    /// A name from `[meshes]`.
    pub mesh: String,
    pub material: String,
    #[serde(default, deserialize_with = "maybe_three")]
    pub translate: Option<[f64; 3]>,
    /// Degrees about x, then y, then z (world axes).
    #[serde(default, deserialize_with = "maybe_three")]
    pub rotate: Option<[f64; 3]>,
    #[serde(default)]
    pub scale: Option<Scale>,
}

/// A mesh file to instance, `[meshes.NAME]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MeshDesc {
    pub file: std::path::PathBuf,
}

impl InstanceDesc {
    /// `translate * rotate * scale`: the mesh is scaled, then rotated about x, y and z in turn,
    /// then moved. Non-finite numbers and singular transforms (a zero scale) are errors.
    pub fn transform(&self, field: &str) -> Result<DAffine3, String> {
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|c| c.is_finite()) {
                Ok(())
            } else {
                Err(format!("{field}.{name}: must be finite numbers, got {v:?}"))
            }
        };
        let t = self.translate.unwrap_or([0.0; 3]);
        finite("translate", &t)?;
        let r = self.rotate.unwrap_or([0.0; 3]);
        finite("rotate", &r)?;
        let s = match self.scale.unwrap_or(Scale::Uniform(1.0)) {
            Scale::Uniform(s) => [s; 3],
            Scale::Axes(a) => a,
        };
        finite("scale", &s)?;
        if s.contains(&0.0) {
            return Err(format!(
                "{field}.scale: a zero scale makes the transform singular, got {s:?}"
            ));
        }
        // Embree maps every ray into the instance's own space by the inverse transform: a
        // scale of 1e-30 made those rays huge, and Debian's Embree aborted the process on them.
        if s.iter()
            .any(|c| !(MIN_SCALE..=MAX_SCALE).contains(&c.abs()))
        {
            return Err(format!(
                "{field}.scale: each component's magnitude must be in [{MIN_SCALE:e}, {MAX_SCALE:e}], got {s:?}"
            ));
        }
        let [rx, ry, rz] = r.map(f64::to_radians);
        // Extrinsic x, then y, then z = intrinsic z-y-x: R = Rz * Ry * Rx.
        let rotation = DQuat::from_euler(EulerRot::ZYX, rz, ry, rx);
        Ok(DAffine3::from_translation(DVec3::from(t))
            * DAffine3::from_mat3(DMat3::from_quat(rotation))
            * DAffine3::from_scale(DVec3::from(s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(translate: [f64; 3], rotate: [f64; 3], scale: Scale) -> InstanceDesc {
        InstanceDesc {
            mesh: "m".into(),
            material: "x".into(),
            translate: Some(translate),
            rotate: Some(rotate),
            scale: Some(scale),
        }
    }

    #[test]
    fn scale_then_rotate_x_y_z_then_translate() {
        let d = desc(
            [1.0, 2.0, 3.0],
            [90.0, 0.0, 0.0],
            Scale::Axes([2.0, 3.0, 4.0]),
        );
        let m = d.transform("i").unwrap();
        // (1, 1, 1) -> scaled (2, 3, 4) -> 90 degrees about x: (x, -z, y) = (2, -4, 3) -> moved.
        let p = m.transform_point3(DVec3::ONE);
        assert!((p - DVec3::new(3.0, -2.0, 6.0)).length() < 1e-12, "{p}");
        // About x, then y: (0, 1, 0) -> x by 90: (0, 0, 1) -> y by 90: (1, 0, 0).
        let d = desc([0.0; 3], [90.0, 90.0, 0.0], Scale::Uniform(1.0));
        let p = d.transform("i").unwrap().transform_vector3(DVec3::Y);
        assert!((p - DVec3::X).length() < 1e-12, "{p}");
    }

    #[test]
    fn bad_transforms_are_errors_naming_the_field() {
        let zero = desc([0.0; 3], [0.0; 3], Scale::Axes([1.0, 0.0, 1.0]));
        assert_eq!(
            zero.transform("instances[3]").unwrap_err(),
            "instances[3].scale: a zero scale makes the transform singular, got [1.0, 0.0, 1.0]"
        );
        let nan = desc([0.0, f64::NAN, 0.0], [0.0; 3], Scale::Uniform(1.0));
        assert_eq!(
            nan.transform("instances[0]").unwrap_err(),
            "instances[0].translate: must be finite numbers, got [0.0, NaN, 0.0]"
        );
    }
}
