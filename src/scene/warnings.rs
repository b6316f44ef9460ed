//! What in a valid scene will make its image black or wrong without any error: no light, no
//! surface, or an object so small next to its coordinates that the ray offsets step over it.
//! The command line prints these as warnings; the scene still renders.

use super::{Light, Material, Scene};
use glam::DVec3;

/// The ray offset over an object's size beyond which the object is warned about. The offset
/// ([`Scene::ray_epsilon`]) is kept at most 1e-3 of the smallest object, but never below ten
/// single-precision steps of the scene's largest coordinate: an object far smaller than its
/// distance from the origin cannot be told apart from its surroundings by Embree.
pub const MAX_OFFSET_OVER_OBJECT: f64 = 0.01;

/// The extent beyond which a scene is warned about: Embree's single-precision hit tests
/// overflow on triangles much larger than about 1e14 (measured: the canonical scene's direct
/// light is right to relRMSE 1e-7 at 1e13 times its size, 17e13 across, and off by 0.17 at
/// 1.3e13 times; the sphere vanishes from view by 1e15). A scene's triangles are at most its
/// extent, so none larger is missed.
pub const MAX_EXTENT: f64 = 1e14;

/// The warnings for `scene`, each one line (without the file name).
pub fn warnings(scene: &Scene) -> Vec<String> {
    let mut out = Vec::new();
    if scene.lights.is_empty() {
        out.push("the scene has no lights: the image will be black".to_string());
    } else if scene.lights.iter().all(|l| strength(l) <= 0.0) {
        out.push("every light's intensity or radiance is zero: the image will be black".into());
    }
    let surfaces = scene
        .meshes
        .iter()
        .filter(|m| !matches!(m.material, Material::Emitter { .. }))
        .count();
    if surfaces == 0 {
        out.push(
            "the scene has no shapes: light falls on nothing and the image will be black".into(),
        );
    }
    if surfaces > 0 && !scene.has_diffuse_surface() {
        out.push(
            "no shape is diffuse: light lands on nothing that scatters it, no photon is stored, \
             and the image shows only the lights, directly or through mirrors and glass"
                .into(),
        );
    }
    if surfaces > 0 {
        out.extend(view_warning(scene));
    }
    for name in &scene.unplaced_meshes {
        out.push(format!(
            "meshes.{name} is placed by no [[instances]]: its file is not read"
        ));
    }
    let extent = scene.extent();
    if extent > MAX_EXTENT {
        out.push(format!(
            "the scene is {extent:.3e} across: Embree's single-precision hit tests overflow on \
             triangles much larger than {MAX_EXTENT:.0e}, and rays miss them; express its \
             lengths in a larger unit"
        ));
    }
    out.extend(far_camera_warning(scene));
    let epsilon = scene.ray_epsilon();
    for (mesh, [lo, hi]) in scene.meshes.iter().zip(scene.mesh_bounds()) {
        let size = (hi - lo).length();
        if size > 0.0 && epsilon > MAX_OFFSET_OVER_OBJECT * size {
            out.push(format!(
                "{} is {size:.3e} across, and rays leave surfaces {epsilon:.3e} off them (ten \
                 single-precision steps at the scene's largest coordinate): its shadow and the \
                 light through it may be wrong; bring the scene's coordinates closer to the \
                 origin or its objects nearer in size",
                mesh.name
            ));
        }
    }
    out
}

/// A warning when the camera stands so far off (or so far from the origin) that single
/// precision cannot place its rays' hits on an object to within [`MAX_OFFSET_OVER_OBJECT`]
/// of its size: Embree tests a camera ray in single precision from the eye, one step of which
/// is `2^-23` of the eye's largest coordinate plus the distance travelled. A glass sphere seen
/// from 1.4e7 away (with a fov to frame it) came out as stripes without a word; from 1.4e4 it
/// was right. The object of the worst ratio is named.
fn far_camera_warning(scene: &Scene) -> Option<String> {
    let eye = scene.camera.eye;
    let step = |[lo, hi]: [DVec3; 2]| {
        let distance = (eye - (lo + hi) * 0.5).length();
        f64::from(f32::EPSILON) * (eye.abs().max_element() + distance)
    };
    let (mesh, size, step) = scene
        .meshes
        .iter()
        .zip(scene.mesh_bounds())
        .filter(|(m, _)| !matches!(m.material, Material::Emitter { .. }))
        .map(|(m, b)| (m, (b[1] - b[0]).length(), step(b)))
        .filter(|&(_, size, step)| size > 0.0 && step > MAX_OFFSET_OVER_OBJECT * size)
        .max_by(|a, b| (a.2 / a.1).total_cmp(&(b.2 / b.1)))?;
    Some(format!(
        "the camera is so far off that single precision places its rays' hits only to about \
         {step:.3e}, and {} is {size:.3e} across: it may come out in stripes; bring the camera \
         nearer (a wider fov_y keeps the framing) or the scene's coordinates nearer the origin",
        mesh.name
    ))
}

/// The least share of the image the scene's box may cover, seen whole in front of the camera,
/// before the view is warned about.
pub const MIN_VIEW_SHARE: f64 = 0.01;

/// A warning when the camera sees none of the scene, or the whole scene in less than
/// [`MIN_VIEW_SHARE`] of the image (`fov_y = 179` shrinks a room to a few pixels): the box of
/// every surface, projected; a box reaching from behind the camera to before it is taken as
/// seen.
fn view_warning(scene: &Scene) -> Option<String> {
    let c = &scene.camera;
    let (lo, hi) = scene
        .meshes
        .iter()
        .zip(scene.mesh_bounds())
        .filter(|(m, _)| !matches!(m.material, Material::Emitter { .. }))
        .fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), (_, [a, b])| (lo.min(a), hi.max(b)),
        );
    let (mut x0, mut y0, mut x1, mut y1) =
        (f64::INFINITY, f64::INFINITY, -f64::INFINITY, -f64::INFINITY);
    let mut behind = 0;
    for k in 0..8 {
        let corner = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        match c.project(corner) {
            Some((x, y)) => (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y)),
            None => behind += 1,
        }
    }
    if behind == 8 {
        return Some("the camera sees none of the scene's shapes: the image will be black".into());
    }
    if behind > 0 {
        return None;
    }
    let (w, h) = (f64::from(c.width), f64::from(c.height));
    let covered = (x1.min(w) - x0.max(0.0)).max(0.0) * (y1.min(h) - y0.max(0.0)).max(0.0);
    if !covered.is_finite() {
        return None;
    }
    if covered <= 0.0 {
        return Some("the camera sees none of the scene's shapes: the image will be black".into());
    }
    let share = covered / (w * h);
    (share < MIN_VIEW_SHARE).then(|| {
        format!(
            "the scene's shapes cover under {}% of the image (at most {} of {} pixels; \
             fov_y = {}): the image will be almost black",
            100.0 * MIN_VIEW_SHARE,
            covered.ceil(),
            u64::from(c.width) * u64::from(c.height),
            shown_fov(c.tan_half_fov)
        )
    })
}

/// The vertical field of view in degrees, as the scene file gave it (to the rounding shown).
fn shown_fov(tan_half_fov: f64) -> String {
    let degrees = 2.0 * tan_half_fov.atan().to_degrees();
    let rounded = (degrees * 1e6).round() / 1e6;
    format!("{rounded}")
}

/// The largest channel of a light's intensity or radiance.
fn strength(light: &Light) -> f64 {
    match light {
        Light::Point { intensity, .. } | Light::Spot { intensity, .. } => intensity.max_element(),
        Light::Quad { radiance, .. } => radiance.max_element(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::file::parse_scene;
    use std::path::Path;

    const CAMERA: &str = "[camera]\neye = [0.0, 2.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
        up = [0.0, 1.0, 0.0]\nfov_y = 40.0\nwidth = 8\nheight = 6\n\
        [materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n";
    const LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0.0, 4.0, 0.0]\n\
        intensity = [10.0, 10.0, 10.0]\n";

    fn floor(half: f64) -> String {
        format!(
            "[[shapes]]\ntype = \"quad\"\ncorner = [{}, 0.0, {half}]\nedge_u = [{}, 0.0, 0.0]\n\
             edge_v = [0.0, 0.0, {}]\nmaterial = \"white\"\n",
            -half,
            2.0 * half,
            -2.0 * half
        )
    }

    const BALL: &str = "[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 1.0\n\
        material = \"white\"\nsegments = 16\n";

    fn warnings_of(text: &str) -> Vec<String> {
        warnings(&parse_scene(text, Path::new(".")).unwrap())
    }

    #[test]
    fn a_lit_scene_of_reasonable_scale_has_none() {
        assert!(warnings_of(&format!("{CAMERA}{LIGHT}{}{BALL}", floor(6.0))).is_empty());
    }

    #[test]
    fn no_light_zero_light_and_no_shape_are_named() {
        assert_eq!(
            warnings_of(&format!("{CAMERA}{}", floor(6.0))),
            ["the scene has no lights: the image will be black"]
        );
        let dark = LIGHT.replace("[10.0, 10.0, 10.0]", "[0.0, 0.0, 0.0]");
        assert_eq!(
            warnings_of(&format!("{CAMERA}{dark}{}", floor(6.0))),
            ["every light's intensity or radiance is zero: the image will be black"]
        );
        assert_eq!(
            warnings_of(&format!("{CAMERA}{LIGHT}")),
            ["the scene has no shapes: light falls on nothing and the image will be black"]
        );
    }

    #[test]
    fn a_scene_out_of_view_or_shrunk_to_a_few_pixels_is_named() {
        let scene = format!("{LIGHT}{}{BALL}", floor(2.0));
        let wide = CAMERA.replace("fov_y = 40.0", "fov_y = 179.0");
        let w = warnings_of(&format!("{wide}{scene}"));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("the scene's shapes cover under 1% of the image (at most 1 of 48 ")
                && w[0].contains("fov_y = 179)"),
            "{w:?}"
        );
        let away = CAMERA.replace("look_at = [0.0, 0.0, 0.0]", "look_at = [0.0, 2.0, 10.0]");
        assert_eq!(
            warnings_of(&format!("{away}{scene}")),
            ["the camera sees none of the scene's shapes: the image will be black"]
        );
        // A camera inside the scene's box sees it.
        let inside = CAMERA.replace("eye = [0.0, 2.0, 5.0]", "eye = [0.0, 0.5, 1.0]");
        assert!(warnings_of(&format!("{inside}{scene}")).is_empty());
        assert!(warnings_of(&format!("{CAMERA}{scene}")).is_empty());
    }

    #[test]
    fn an_object_in_a_huge_scene_keeps_its_offsets_small_and_one_lost_in_it_is_named() {
        // A floor 10^5 across under a ball 3.5 across: the offset was 2e-5 of the extent, 2.8,
        // and the ball vanished; it is now 1e-3 of the ball, raised to ten single-precision
        // steps at the floor's edge (5e-7 * 5e4 = 0.025), and nothing is left to warn about.
        let huge = parse_scene(
            &format!("{CAMERA}{LIGHT}{}{BALL}", floor(5e4)),
            Path::new("."),
        )
        .unwrap();
        assert!(
            (huge.ray_epsilon() - 0.025).abs() < 1e-9,
            "{}",
            huge.ray_epsilon()
        );
        assert!(warnings(&huge).is_empty(), "{:?}", warnings(&huge));
        // A scene of ordinary proportions keeps 2e-5 of its extent.
        let plain = parse_scene(
            &format!("{CAMERA}{LIGHT}{}{BALL}", floor(6.0)),
            Path::new("."),
        )
        .unwrap();
        assert_eq!(plain.ray_epsilon(), 2e-5 * plain.extent());
        // At 10^7 across, single precision cannot place the ball's surface to within 1% of it.
        let w = warnings_of(&format!("{CAMERA}{LIGHT}{}{BALL}", floor(5e6)));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with(
                "shapes[1] (sphere) is 3.464e0 across, and rays leave surfaces 2.500e0 off them"
            ),
            "{w:?}"
        );
    }

    #[test]
    fn a_camera_too_far_off_for_single_precision_is_named() {
        // Framed as near: the sphere 2 across fills the view at every distance.
        let far = |d: f64| {
            let fov = 2.0 * (1.5f64 / (d * 2f64.sqrt())).atan().to_degrees();
            CAMERA
                .replace(
                    "eye = [0.0, 2.0, 5.0]",
                    &format!("eye = [0.0, {d:e}, {d:e}]"),
                )
                .replace("fov_y = 40.0", &format!("fov_y = {fov:e}"))
                + "[[shapes]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
                 material = \"white\"\nsegments = 16\n"
                + LIGHT
        };
        assert!(
            warnings_of(&far(1e4)).is_empty(),
            "{:?}",
            warnings_of(&far(1e4))
        );
        let w = warnings_of(&far(1e7));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with(
                "the camera is so far off that single precision places its rays' hits only to \
                 about 2.878e0, and shapes[0] (sphere) is 3.464e0 across"
            ),
            "{w:?}"
        );
    }

    #[test]
    fn a_mesh_no_instance_places_is_named_and_not_read() {
        // Its file does not exist: not read, so not an error (a broken one was not either).
        let ghost = "[meshes.ghost]\nfile = \"no-such-file.ply\"\n";
        assert_eq!(
            warnings_of(&format!("{CAMERA}{LIGHT}{}{BALL}{ghost}", floor(6.0))),
            ["meshes.ghost is placed by no [[instances]]: its file is not read"]
        );
    }

    #[test]
    fn a_scene_too_large_for_single_precision_is_named() {
        // A floor 2e14 across is 2.8e14 from corner to corner; 6e13 (8.5e13) is not warned.
        let w = warnings_of(&format!("{CAMERA}{LIGHT}{}", floor(1e14)));
        assert_eq!(
            w,
            [
                "the scene is 2.828e14 across: Embree's single-precision hit tests overflow on \
              triangles much larger than 1e14, and rays miss them; express its lengths in a \
              larger unit"
            ]
        );
        assert!(warnings_of(&format!("{CAMERA}{LIGHT}{}", floor(3e13))).is_empty());
    }
}
