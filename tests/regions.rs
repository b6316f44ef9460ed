//! The regions a render is judged on: a pixel counts as diffuse only when its whole area sees
//! diffuse surfaces, since the light-traced reference holds nothing for what a pixel shows
//! through glass or in a mirror.

use photondiff::embree::Device;
use photondiff::reference::metrics::Regions;
use photondiff::render::film::Film;
use photondiff::scene::file::parse_scene;

/// A floor seen straight down with a glass pane floating above it: in the image the pane is an
/// axis-aligned rectangle, known from the camera's projection of its corners.
const SCENE: &str = r#"
[camera]
eye = [0.0, 4.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_y = 40.0
width = 64
height = 48

[materials.floor]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[materials.glass]
type = "glass"
ior = 1.5

[[lights]]
type = "point"
position = [0.0, 3.0, 0.0]
intensity = [10.0, 10.0, 10.0]

[[shapes]]
type = "quad"
corner = [-5.0, 0.0, 5.0]
edge_u = [10.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -10.0]
material = "floor"

[[shapes]]
type = "quad"
corner = [-0.37, 1.0, 0.29]
edge_u = [0.81, 0.0, 0.0]
edge_v = [0.0, 0.0, -0.53]
material = "glass"
"#;

#[test]
fn pixels_partly_covered_by_glass_are_not_judged_as_diffuse() {
    let dir = tempfile::tempdir().unwrap();
    let scene = parse_scene(SCENE, dir.path()).unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let c = &scene.camera;
    let (w, h) = (c.width as usize, c.height as usize);
    // A dim reference (1e-3, far below the floor's direct light) with a bright 6 x 6 block in
    // the top-left corner, where the floor is clear of the pane: the block is a caustic (more
    // than 1.5 times the direct light), every judged pixel is lit.
    let mut reference = Film::new(c.width, c.height);
    let block = |i: usize| i % w < 6 && i / w < 6;
    for (i, p) in reference.pixels.iter_mut().enumerate() {
        *p = glam::DVec3::splat(if block(i) { 1e3 } else { 1e-3 });
    }
    let regions = Regions::new(&scene, &embree, &reference);

    // The pane's rectangle in continuous pixel coordinates.
    let corners = [[-0.37, 0.29], [0.44, 0.29], [-0.37, -0.24], [0.44, -0.24]]
        .map(|[x, z]| c.project(glam::DVec3::new(x, 1.0, z)).unwrap());
    let x0 = corners.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let x1 = corners
        .iter()
        .map(|p| p.0)
        .fold(f64::NEG_INFINITY, f64::max);
    let y0 = corners.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let y1 = corners
        .iter()
        .map(|p| p.1)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(x1 - x0 > 8.0 && y1 - y0 > 5.0, "pane {x0} {x1} {y0} {y1}");

    let mut partly = 0;
    for y in 0..h {
        for x in 0..w {
            let judged = regions.diffuse.contains(&(y * w + x));
            // The overlap of the pixel's square with the pane's rectangle.
            let ox = (x1.min(x as f64 + 1.0) - x0.max(x as f64)).max(-1.0);
            let oy = (y1.min(y as f64 + 1.0) - y0.max(y as f64)).max(-1.0);
            let centre_on_floor =
                !(x0..x1).contains(&(x as f64 + 0.5)) || !(y0..y1).contains(&(y as f64 + 0.5));
            if ox < -1e-9 || oy < -1e-9 {
                // Clear of the pane: the whole pixel sees the floor.
                assert!(
                    judged,
                    "pixel ({x}, {y}) sees only the floor but is not judged"
                );
            } else if ox >= 0.25 && oy >= 0.25 {
                // A quarter of a pixel or more on either side shows the pane.
                assert!(!judged, "pixel ({x}, {y}) shows the pane but is judged");
                if centre_on_floor {
                    partly += 1;
                }
            }
        }
    }
    // The pixels the old rule (the centre ray alone) judged though they show the pane: the
    // rectangle's rim, on all four sides.
    assert!(
        partly >= 2 * 8,
        "{partly} pixels with their centre on the floor show the pane"
    );
    // The lit, caustic and shadow regions are drawn from the judged pixels only: every judged
    // pixel is lit, the caustic is the block, and the floor in the pane's shadow that the
    // camera sees past the pane (the light is nearer the pane than the camera, so the shadow
    // is wider than the pane's image) is the shadow.
    assert_eq!(regions.lit, regions.diffuse);
    let expected: Vec<usize> = (0..w * h).filter(|&i| block(i)).collect();
    assert_eq!(regions.caustic, expected);
    assert!(!regions.shadow.is_empty());
    assert!(regions.shadow.iter().all(|i| !block(*i)));
    for i in regions
        .caustic
        .iter()
        .chain(&regions.shadow)
        .chain(&regions.lit)
    {
        assert!(regions.diffuse.contains(i));
    }
}
