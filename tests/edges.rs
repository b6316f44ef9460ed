//! Pixels on geometric edges (`--edge-grid`): which pixels they are, that they alone are
//! rendered on the finer grid, and that final gathering spends a pixel's rays over its cells.

mod common;
use common::render_stats;
use photondiff::embree::{Device, Ray};
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::options::PhotonOptions;
use photondiff::render::edges::{
    edge_pixels, finer_than_the_pixel, same_surface, CornerHit, EdgeMask,
};
use photondiff::render::film::Film;
use photondiff::render::passes::{Progressive, StopRules, DEFAULT_ALPHA, DEFAULT_GLOBAL_ALPHA};
use photondiff::render::split::Window;
use photondiff::render::stats::Stats;
use photondiff::render::{render, RenderOptions, TILE_SIZE};
use photondiff::scene::file::parse_scene;
use photondiff::scene::Scene;
use std::path::Path;
use std::process::Command;

/// The canonical scene (a glass sphere on a floor under a point light) at 160 x 120.
fn small_canonical() -> Scene {
    let text = include_str!("../scenes/caustic-sphere.toml")
        .replace("width = 640", "width = 160")
        .replace("height = 480", "height = 120");
    parse_scene(&text, Path::new(".")).unwrap()
}

#[test]
fn edge_pixels_are_those_whose_corner_rays_meet_different_surfaces() {
    let scene = small_canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    // One ray at a time through each pixel corner: the first surface met, if any.
    let surface = |x: u32, y: u32| {
        let r = scene.camera.ray(x as f64, y as f64, 1.0);
        embree
            .intersect(&Ray::new(r.p, r.d))
            .map(|hit| CornerHit::of(&scene, &hit))
    };
    let (whole, rays) = edge_pixels(&scene, &embree, (0, 0, w, h));
    assert_eq!(rays, ((w + 1) * (h + 1)) as u64);
    let mut edges = 0;
    for y in 0..h {
        for x in 0..w {
            let corners = [
                surface(x, y),
                surface(x + 1, y),
                surface(x, y + 1),
                surface(x + 1, y + 1),
            ];
            let expected = (0..4)
                .any(|a| (a + 1..4).any(|b| !same_surface(corners[a], corners[b])))
                && !finer_than_the_pixel(&corners);
            assert_eq!(whole[(y * w + x) as usize], expected, "pixel ({x}, {y})");
            edges += expected as usize;
        }
    }
    // The sphere's outline and the floor's far edge: a thin line of pixels, not an area.
    assert!(
        edges > 200 && edges < (w * h / 20) as usize,
        "{edges} edge pixels"
    );
    // Tiles tell the same pixels: their corner rays at the tile borders are the same rays.
    for ty in (0..h).step_by(TILE_SIZE as usize) {
        for tx in (0..w).step_by(TILE_SIZE as usize) {
            let (x1, y1) = ((tx + TILE_SIZE).min(w), (ty + TILE_SIZE).min(h));
            let (tile, _) = edge_pixels(&scene, &embree, (tx, ty, x1, y1));
            for y in ty..y1 {
                for x in tx..x1 {
                    let k = ((y - ty) * (x1 - tx) + (x - tx)) as usize;
                    assert_eq!(tile[k], whole[(y * w + x) as usize], "pixel ({x}, {y})");
                }
            }
        }
    }
}

/// One mesh folded along a line (two quads meeting at a right angle, one OBJ file), seen across
/// the fold: the pixels on the crease are edge pixels although every corner ray meets the same
/// mesh, and the pixels on either flat side are not.
#[test]
fn a_crease_in_one_mesh_is_an_edge() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("fold.obj"),
        "v -10 0 -2\nv 10 0 -2\nv 10 0 10\nv -10 0 10\nv -10 10 -2\nv 10 10 -2\n\
         f 1 4 3\nf 1 3 2\nf 1 2 6\nf 1 6 5\n",
    )
    .unwrap();
    let scene = parse_scene(
        r#"
[camera]
eye = [0.3, 1.5, 3.0]
look_at = [0.0, 0.5, -2.0]
up = [0.0, 1.0, 0.0]
fov_y = 50.0
width = 64
height = 48

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = [1.0, 1.0, 1.0]

[[shapes]]
type = "mesh"
file = "fold.obj"
material = "white"
"#,
        dir.path(),
    )
    .unwrap();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (edge, _) = edge_pixels(&scene, &embree, (0, 0, w, h));
    // The fold (y = 0, z = -2) projects to one row per column: where the centre ray's hit
    // changes from the floor to the wall.
    let on_wall = |x: u32, y: u32| {
        let r = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
        let hit = embree
            .intersect(&Ray::new(r.p, r.d))
            .expect("the fold fills the view");
        hit.geometric_normal.y.abs() < 0.5
    };
    for x in 0..w {
        let fold = (1..h)
            .find(|&y| on_wall(x, y - 1) && !on_wall(x, y))
            .expect("a fold");
        assert!(
            edge[((fold - 1) * w + x) as usize] || edge[(fold * w + x) as usize],
            "column {x}: the fold at row {fold} is not an edge"
        );
    }
    let flagged = edge.iter().filter(|&&e| e).count() as u32;
    assert!(flagged >= w && flagged <= 3 * w, "{flagged} edge pixels");
}

/// A glass sheet rippled far finer than a pixel (its normal turns within nearly every pixel it
/// covers), in front of a second, flat sheet of the same mesh further back: inside the rippled
/// sheet no pixel is an edge, where the crease rule alone flagged most; on its outline against
/// the sheet behind (one mesh, a jump in distance) every pixel the crease rule flags is still
/// flagged. The same ripples in a diffuse mesh are creases, as before.
#[test]
fn ripples_finer_than_a_pixel_in_glass_are_no_edges_but_its_outlines_are() {
    let dir = tempfile::tempdir().unwrap();
    // Rippled sheet: x in [-1, 1], y in [0, 2], at z = 0, displaced along z by 0.01 (sin 150 x
    // + sin 150 y): a period of 0.04, under half a pixel at this distance, and ten triangles
    // to a pixel along each axis, so that a pixel's corners meet three or four facets. Then a
    // flat sheet of the same mesh behind its top, wider, leaning back by 30 degrees.
    let mut obj = String::new();
    let (nx, ny) = (200, 200);
    for j in 0..=ny {
        for i in 0..=nx {
            let x = -1.0 + 2.0 * i as f64 / nx as f64;
            let y = 2.0 * j as f64 / ny as f64;
            let z = 0.01 * ((150.0 * x).sin() + (150.0 * y).sin());
            obj += &format!("v {x} {y} {z}\n");
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let v = |i: usize, j: usize| j * (nx + 1) + i + 1;
            obj += &format!("f {} {} {}\n", v(i, j), v(i + 1, j), v(i + 1, j + 1));
            obj += &format!("f {} {} {}\n", v(i, j), v(i + 1, j + 1), v(i, j + 1));
        }
    }
    let base = (nx + 1) * (ny + 1);
    obj += "v -4 1.5 -3\nv 4 1.5 -3\nv 4 4 -4.4375\nv -4 4 -4.4375\n";
    obj += &format!("f {} {} {}\n", base + 1, base + 2, base + 3);
    obj += &format!("f {} {} {}\n", base + 1, base + 3, base + 4);
    std::fs::write(dir.path().join("sheets.obj"), obj).unwrap();
    let scene_of = |material: &str| {
        parse_scene(
            &format!(
                r#"
[camera]
eye = [0.0, 1.0, 6.0]
look_at = [0.0, 1.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 64
height = 48

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[materials.glass]
type = "glass"
ior = 1.5

[[lights]]
type = "point"
position = [0.0, 3.0, 3.0]
intensity = [1.0, 1.0, 1.0]

[[shapes]]
type = "mesh"
file = "sheets.obj"
material = "{material}"
"#
            ),
            dir.path(),
        )
        .unwrap()
    };
    // Per pixel: whether all, some or none of its corners meet the rippled sheet, its flag,
    // and what the crease rule alone (any two corners not one smooth surface) says.
    let pixels = |scene: &Scene| {
        let device = Device::new().unwrap();
        let embree = scene.build_embree(&device).unwrap();
        let (w, h) = (scene.camera.width, scene.camera.height);
        let (edge, _) = edge_pixels(scene, &embree, (0, 0, w, h));
        let corner = |x: u32, y: u32| {
            let r = scene.camera.ray(x as f64, y as f64, 1.0);
            embree
                .intersect(&Ray::new(r.p, r.d))
                .map(|hit| CornerHit::of(scene, &hit))
        };
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let c = [
                    corner(x, y),
                    corner(x + 1, y),
                    corner(x, y + 1),
                    corner(x + 1, y + 1),
                ];
                let on = c
                    .iter()
                    .filter(|c| c.is_some_and(|c| c.distance < 7.0))
                    .count();
                let crease = (0..4).any(|a| (a + 1..4).any(|b| !same_surface(c[a], c[b])));
                out.push((on, edge[(y * w + x) as usize], crease));
            }
        }
        out
    };
    let glass = pixels(&scene_of("glass"));
    let inside: Vec<_> = glass.iter().filter(|p| p.0 == 4).collect();
    let outline: Vec<_> = glass.iter().filter(|p| p.0 > 0 && p.0 < 4).collect();
    let creases = inside.iter().filter(|p| p.2).count();
    assert!(inside.len() > 300, "{} pixels inside", inside.len());
    assert!(
        creases > inside.len() * 2 / 3,
        "{creases} of {} inside are creases",
        inside.len()
    );
    assert!(inside.iter().all(|p| !p.1), "ripples in glass flagged");
    assert!(outline.len() > 30, "{} outline pixels", outline.len());
    assert!(
        outline.iter().all(|p| p.1 == p.2),
        "an outline pixel lost its flag"
    );
    let flagged = outline.iter().filter(|p| p.1).count();
    assert!(
        flagged > outline.len() / 2,
        "{flagged} of {} outline pixels flagged",
        outline.len()
    );
    // Diffuse: the rule is the crease rule, pixel for pixel.
    let diffuse = pixels(&scene_of("white"));
    assert!(diffuse.iter().all(|p| p.1 == p.2));
    assert_eq!(
        diffuse.iter().filter(|p| p.0 == 4 && p.1).count(),
        creases,
        "the same ripples, diffuse"
    );
}

#[test]
fn edge_pixels_render_as_the_finer_grid_and_the_rest_as_before() {
    let scene = small_canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (edge, _) = edge_pixels(&scene, &embree, (0, 0, w, h));
    let direct = |options: RenderOptions| -> (Film, Stats) {
        let mut stats = Stats::default();
        let film = render(&scene, &embree, &[], &options.with_threads(2), &mut stats).unwrap();
        (film, stats)
    };
    let (one, _) = direct(RenderOptions::default());
    let (four, _) = direct(RenderOptions::default().with_view_grid(4));
    let (split, stats) = direct(RenderOptions::default().with_edge_grid(4));
    let edges = edge.iter().filter(|&&e| e).count();
    assert_eq!(stats.edge_pixels, edges as u64);
    // Camera rays: one per pixel, 15 more per edge pixel, and each tile's corners.
    let t = TILE_SIZE;
    let corners: u32 = (0..h.div_ceil(t))
        .flat_map(|ty| (0..w.div_ceil(t)).map(move |tx| (tx, ty)))
        .map(|(tx, ty)| ((t * (tx + 1)).min(w) - t * tx + 1) * ((t * (ty + 1)).min(h) - t * ty + 1))
        .sum();
    assert_eq!(
        stats.rays.camera,
        (w * h) as u64 + 15 * edges as u64 + corners as u64
    );
    let mut differ = 0;
    for (i, &on_edge) in edge.iter().enumerate() {
        let expected = if on_edge {
            four.pixels[i]
        } else {
            one.pixels[i]
        };
        assert!(
            (split.pixels[i] - expected).abs().max_element() <= 1e-12 * expected.max_element(),
            "pixel {i} (edge {on_edge}): {} against {}",
            split.pixels[i],
            expected
        );
        differ += (on_edge && (four.pixels[i] - one.pixels[i]).max_element().abs() > 1e-3) as usize;
    }
    // The finer grid changes the edge pixels (the test would pass vacuously otherwise).
    assert!(
        differ > edges / 4,
        "only {differ} of {edges} edge pixels changed"
    );
    // An edge grid no finer than the view grid changes nothing.
    let (same, stats) = direct(RenderOptions::default().with_view_grid(4).with_edge_grid(4));
    assert!(same == four);
    assert_eq!(stats.edge_pixels, 0);
}

/// A closed diffuse sphere with a diffuse ball inside, under a point light: every gather ray
/// is one segment, and the ball's outline makes edge pixels.
const BALL_IN_A_SPHERE: &str = r#"
[camera]
eye = [0.0, 0.0, 0.6]
look_at = [0.0, -0.2, -1.0]
up = [0.0, 1.0, 0.0]
fov_y = 60.0
width = 40
height = 30

[materials.wall]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0.0, 0.5, 0.0]
intensity = [1.0, 1.0, 1.0]

[[shapes]]
type = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "wall"
segments = 64

[[shapes]]
type = "sphere"
center = [0.0, -0.3, -0.5]
radius = 0.25
material = "wall"
segments = 64
"#;

/// Renders `BALL_IN_A_SPHERE` with `--estimator pd --photons 2000` and `args`; returns the
/// statistics JSON.
fn ball_stats(args: &[&str]) -> serde_json::Value {
    ball_stats_as("pd", args)
}

/// Renders `BALL_IN_A_SPHERE` with `--estimator ESTIMATOR --photons 2000` and `args`; returns
/// the statistics JSON.
fn ball_stats_as(estimator: &str, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["--quiet", "--estimator", estimator, "--photons", "2000"];
    all.extend_from_slice(args);
    render_stats(BALL_IN_A_SPHERE, &all)
}

/// With final gathering on, edge pixels are split 4 x 4 by default (`--edge-grid` left out),
/// and each cell spends its share of the pixel's gather rays; without it the default is off.
#[test]
fn final_gathering_spends_an_edge_pixels_rays_over_its_cells() {
    let json = ball_stats(&["--gather-rays", "16", "--gather-near", "0"]);
    let count = |v: &serde_json::Value| v.as_u64().unwrap();
    let edges = count(&json["edge_pixels"]);
    let gathers = &json["gathers"];
    let pixels = 40 * 30;
    assert!(edges > 10 && edges < pixels / 4, "{edges} edge pixels");
    // Each edge pixel gathers in 16 cells of one ray each; every other pixel gathers 16 rays.
    assert_eq!(
        count(&gathers["final_gathers"]),
        pixels - edges + 16 * edges
    );
    assert_eq!(count(&gathers["gather_rays"]), 16 * pixels);
    assert_eq!(ball_stats(&[])["edge_pixels"].as_u64(), Some(0));
}

#[test]
fn bad_edge_grids_are_clear_errors() {
    for bad in ["0", "65", "-1"] {
        let out = Command::new(env!("CARGO_BIN_EXE_photondiff"))
            .args([
                "render",
                &format!("--edge-grid={bad}"),
                "scenes/caustic-sphere.toml",
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.starts_with(&format!(
                "error: invalid value '{bad}' for '--edge-grid <N>': {bad} is not in 1..=64\n"
            )),
            "--edge-grid {bad}: {stderr}"
        );
    }
}

/// An `--edge-grid` given no finer than `--view-grid` is off, as its help says, and the render
/// says so (it was off without a word); the documented off value, 1, and a finer grid are not
/// warned about.
#[test]
fn an_edge_grid_no_finer_than_the_view_grid_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, BALL_IN_A_SPHERE).unwrap();
    let warnings = |grids: &[&str]| {
        let out = common::run_ok(
            [
                "render",
                scene.to_str().unwrap(),
                "--quiet",
                "--photons",
                "2000",
                "-o",
                dir.path().join("image.exr").to_str().unwrap(),
            ]
            .iter()
            .chain(grids),
        );
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .filter(|l| l.contains("warning"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        warnings(&["--edge-grid", "4", "--view-grid", "4"]),
        [
            "photondiff: warning: --edge-grid 4 is no finer than --view-grid 4: edge pixels are \
          rendered on the view grid (an edge grid above the view grid refines them)"
        ]
    );
    assert_eq!(warnings(&["--edge-grid", "2", "--view-grid", "3"]).len(), 1);
    assert!(warnings(&["--edge-grid", "1"]).is_empty());
    assert!(warnings(&["--edge-grid", "4", "--view-grid", "2"]).is_empty());
}

/// Corner rays [`EdgeMask::find`] traces over a `w x h` image: bands of `TILE_SIZE` rows, each with its
/// own rows of corners.
fn band_corners(w: u32, h: u32) -> u64 {
    (0..h)
        .step_by(TILE_SIZE as usize)
        .map(|y| (w as u64 + 1) * (((y + TILE_SIZE).min(h) - y) as u64 + 1))
        .sum()
}

#[test]
fn an_edge_mask_found_once_renders_as_edges_found_tile_by_tile() {
    let scene = small_canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (edge, _) = edge_pixels(&scene, &embree, (0, 0, w, h));
    let (mask, corner_rays) = EdgeMask::find(&scene, &embree, Window::full(w, h));
    assert_eq!(mask.tile((0, 0, w, h)).unwrap(), edge);
    let edges = edge.iter().filter(|&&e| e).count();
    assert!(edges > 100, "{edges} edge pixels");
    assert_eq!(mask.count(), edges);
    assert_eq!(corner_rays, band_corners(w, h));
    // A tile's flags are the mask's rows and columns of it.
    let tile = mask.tile((16, 32, 48, 40)).unwrap();
    for (k, &flag) in tile.iter().enumerate() {
        let (x, y) = (16 + k as u32 % 32, 32 + k as u32 / 32);
        assert_eq!(flag, edge[(y * w + x) as usize]);
    }
    let options = RenderOptions::default().with_edge_grid(4).with_threads(2);
    let direct = |options: &RenderOptions| -> (Film, Stats) {
        let mut stats = Stats::default();
        let film = render(&scene, &embree, &[], options, &mut stats).unwrap();
        (film, stats)
    };
    let (per_tile, tiled) = direct(&options);
    let (once, found) = direct(&options.clone().with_edges(Some(mask)));
    assert!(
        once == per_tile,
        "the image depends on where the edges were found"
    );
    assert_eq!(found.edge_pixels, tiled.edge_pixels);
    // No corner rays in the render itself: one ray per pixel and 15 more per edge pixel.
    assert_eq!(found.rays.camera, (w * h) as u64 + 15 * edges as u64);
    // A mask of part of the image: the tiles outside it find their own edges.
    let (part, _) = EdgeMask::find(&scene, &embree, Window::full(32, 32));
    assert_eq!(part.tile((32, 0, 48, 16)), None);
    let (partly, _) = direct(&options.clone().with_edges(Some(part)));
    assert!(partly == per_tile);
}

#[test]
fn a_progressive_run_finds_its_edge_pixels_once() {
    let scene = small_canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (mask, _) = EdgeMask::find(&scene, &embree, Window::full(w, h));
    let edges = mask.count() as u64;
    let photons = PhotonOptions::default();
    let run = Progressive {
        scene: &scene,
        embree: &embree,
        photons: photons.clone(),
        estimator: EstimatorSettings {
            ms_grid: 4,
            ..EstimatorSettings::new(EstimatorKind::Direct, photons.limits(&scene).max_radius)
        },
        render: RenderOptions::default().with_edge_grid(4).with_threads(2),
        alpha: DEFAULT_ALPHA,
        global_alpha: DEFAULT_GLOBAL_ALPHA,
    };
    let stop = StopRules {
        passes: Some(3),
        ..StopRules::default()
    };
    let mut stats = Stats::default();
    let sum = run.run(&stop, false, &mut stats).unwrap();
    assert_eq!(sum.passes, 3);
    assert_eq!(stats.edge_pixels, 3 * edges);
    // Three passes of one ray per pixel and 16 per edge pixel; the corners once.
    assert_eq!(
        stats.rays.camera,
        3 * ((w * h) as u64 + 15 * edges) + band_corners(w, h)
    );
    // The same passes rendered as a range (what a cluster's worker does) give the same sum.
    let mut range_stats = Stats::default();
    let range = run.render_range(0..3, &mut range_stats).unwrap();
    assert!(range.mean() == sum.mean());
    assert_eq!(range_stats.rays.camera, stats.rays.camera);
}

/// `integrated` splits edge pixels by default in a long run only (more than its 2 passes, a
/// time budget or a target noise), where their bias would outlast the noise; the other
/// estimators keep the thesis's one ray a pixel; an explicit `--edge-grid` wins.
#[test]
fn a_long_integrated_run_splits_edge_pixels_by_default() {
    let edges = |estimator: &str, args: &[&str]| {
        ball_stats_as(estimator, args)["edge_pixels"]
            .as_u64()
            .unwrap()
    };
    assert_eq!(edges("integrated", &[]), 0);
    assert_eq!(edges("integrated", &["--passes", "2"]), 0);
    let three = edges("integrated", &["--passes", "3"]);
    assert!(
        three > 30 && three.is_multiple_of(3),
        "{three} edge pixels over 3 passes"
    );
    let budget = edges("integrated", &["--time-budget", "0.5"]);
    assert!(budget > 0 && budget.is_multiple_of(three / 3), "{budget}");
    assert_eq!(
        edges("integrated", &["--passes", "3", "--edge-grid", "1"]),
        0
    );
    assert_eq!(edges("pd", &["--passes", "3"]), 0);
    assert_eq!(edges("multisampled", &["--passes", "3"]), 0);
}
