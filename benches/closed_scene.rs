//! The closed scene (`scenes/cornell-glass.toml`): every wall's mean and per-pixel error against
//! the split reference, for the global map seen directly (`pd`, and the default `integrated`)
//! and for final gathering, with each render's whole-process time.
//!
//! The reference is made on first use and cached in `out/reference/` (direct light on 16 x 16
//! and 17 x 17 rays per pixel, the rest light-traced; its noise per wall from its two halves is
//! printed beside every error, since it bounds what an error can show).
//!
//! Run: `cargo bench --bench closed_scene`. Environment: `PHOTONDIFF_REFERENCE_PATHS` (light
//! paths of each kind in the reference, default 4*10^7), `PHOTONDIFF_GATHER_ARGS` (the options
//! of the final-gathering render, default `--gather-rays 64 --edge-grid 4 --time-budget 27`:
//! the 30 s for the whole process).

use photondiff::embree::Ray;
use photondiff::reference::metrics::rel_rmse;
use photondiff::render::film::Film;
use photondiff::scene::Material;
use std::path::PathBuf;

#[path = "common/mod.rs"]
mod common;
use common::{env_or, render_process as render, scene_with_reference};

fn mean(film: &Film, pixels: &[usize]) -> f64 {
    pixels
        .iter()
        .map(|&i| film.pixels[i].element_sum() / 3.0)
        .sum::<f64>()
        / pixels.len().max(1) as f64
}

fn main() -> Result<(), String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let scene_path = root.join("scenes/cornell-glass.toml");
    let out = root.join("out");
    let dir = out.join("closed_scene");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let paths: u64 = env_or("PHOTONDIFF_REFERENCE_PATHS", 40_000_000);
    let gather_args: String = env_or(
        "PHOTONDIFF_GATHER_ARGS",
        "--gather-rays 64 --edge-grid 4 --time-budget 27".to_string(),
    );

    let (scene, embree, reference) =
        scene_with_reference("cornell-glass.toml", "cornell-glass", paths, paths)?;

    // The walls: pixels whose centre ray first meets each diffuse quad. The reference holds
    // only direct light where a pixel sees a mirror or glass (a light path cannot reach the
    // pinhole through them), so a pixel part of which sees a sphere cannot be judged against
    // it: each wall's pixels are judged without those whose 4 x 4 sub-pixel rays meet a
    // specular surface first (`partly specular`), whose error is printed apart.
    let c = &scene.camera;
    let first_material = |x: f64, y: f64| {
        let r = c.ray(x, y, 1.0);
        embree
            .intersect(&Ray::new(r.p, r.d))
            .map(|hit| (hit.geom_id, scene.material(hit.geom_id)))
    };
    let mut walls: Vec<(u32, Vec<usize>)> = Vec::new();
    let mut partly_specular: Vec<(u32, Vec<usize>)> = Vec::new();
    for y in 0..c.height as usize {
        for x in 0..c.width as usize {
            let Some((geom, material)) = first_material(x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            if !matches!(material, Material::Diffuse { .. }) {
                continue;
            }
            let sees_specular = (0..16).any(|k| {
                let (sx, sy) = ((k % 4) as f64 + 0.5, (k / 4) as f64 + 0.5);
                first_material(x as f64 + sx / 4.0, y as f64 + sy / 4.0)
                    .is_some_and(|(_, m)| !matches!(m, Material::Diffuse { .. }))
            });
            let i = y * c.width as usize + x;
            let set = if sees_specular {
                &mut partly_specular
            } else {
                &mut walls
            };
            match set.iter_mut().find(|(g, _)| *g == geom) {
                Some((_, px)) => px.push(i),
                None => set.push((geom, vec![i])),
            }
        }
    }
    partly_specular.sort_by_key(|(g, _)| *g);
    walls.sort_by_key(|(g, _)| *g);

    let methods: Vec<(String, Vec<String>)> = vec![
        (
            "Regular 1x1 (`--estimator pd`)".into(),
            vec!["--estimator".into(), "pd".into()],
        ),
        ("default (global map seen directly)".into(), vec![]),
        (
            format!("`{gather_args}`"),
            gather_args.split_whitespace().map(String::from).collect(),
        ),
    ];
    let mut rows = Vec::new();
    for (k, (name, args)) in methods.iter().enumerate() {
        let file = dir.join(format!("method{k}.exr"));
        let seconds = render(&scene_path, &file, args)?;
        eprintln!("{name}: {seconds:.1} s");
        rows.push((name, seconds, Film::read_exr(&file)?));
    }

    println!("\n## The closed scene (`scenes/cornell-glass.toml`), per wall\n");
    println!(
        "Reference: {paths} + {paths} light paths, direct light on 16x16 and 17x17 rays. Each \
         cell: mean / reference mean, and relRMSE = sqrt(mean over pixels and channels of \
         (I - R)^2) / mean(R) over the wall's pixels (those no part of which sees a mirror or \
         glass).\n"
    );
    print!("| wall | pixels | reference noise |");
    for (name, seconds, _) in &rows {
        print!(" {name}, {seconds:.1} s |");
    }
    println!();
    println!("|---|---|---|{}", "---|".repeat(rows.len()));
    let mut resolution = common::Resolution::default();
    for (geom, px) in &walls {
        let noise = reference.relative_noise(px);
        print!(
            "| {} | {} | {:.2}% |",
            scene.meshes[*geom as usize].name,
            px.len(),
            100.0 * noise
        );
        for (_, _, film) in &rows {
            print!(
                " x{:.4}, {} |",
                mean(film, px) / mean(&reference.film, px),
                resolution.cell(rel_rmse(film, &reference.film, px), noise, 2, true)
            );
        }
        println!();
    }
    if resolution.any() {
        println!("\n{}", resolution.note("PHOTONDIFF_REFERENCE_PATHS"));
    }

    println!(
        "\nPixels whose centre ray meets the wall but part of which sees a mirror or glass \
         sphere (not judged above: the reference lacks what the sphere shows there), the last \
         render:\n"
    );
    println!("| wall | pixels | relRMSE over them | relRMSE over all the wall's pixels |");
    println!("|---|---|---|---|");
    let (_, _, last) = rows.last().expect("three renders");
    for (geom, px) in &partly_specular {
        let all: Vec<usize> = walls
            .iter()
            .filter(|(g, _)| g == geom)
            .flat_map(|(_, p)| p.iter().copied())
            .chain(px.iter().copied())
            .collect();
        let wall_mean = mean(&reference.film, &all);
        let rms = |pixels: &[usize]| {
            rel_rmse(last, &reference.film, pixels) * mean(&reference.film, pixels) / wall_mean
        };
        println!(
            "| {} | {} | {:.2}% | {:.2}% |",
            scene.meshes[*geom as usize].name,
            px.len(),
            100.0 * rms(px),
            100.0 * rms(&all)
        );
    }

    // Where the last render's error lies: a wall whose error sits in a few pixels has a local
    // cause (a caustic's focus, an edge), one spread over it a noise or bias of the whole.
    let (_, _, film) = rows.last().expect("three renders");
    let width = scene.camera.width as usize;
    println!("\nThe last render's worst 1% of each wall's pixels: their share of the wall's squared error, and where they lie (the quartiles of their x and y).\n");
    println!("| wall | share | x quartiles | y quartiles |");
    println!("|---|---|---|---|");
    for (geom, px) in &walls {
        let mut errors: Vec<(f64, usize)> = px
            .iter()
            .map(|&i| {
                (
                    (film.pixels[i] - reference.film.pixels[i]).length_squared(),
                    i,
                )
            })
            .collect();
        errors.sort_by(|a, b| b.0.total_cmp(&a.0));
        let worst = &errors[..(errors.len() / 100).max(1)];
        let share =
            worst.iter().map(|e| e.0).sum::<f64>() / errors.iter().map(|e| e.0).sum::<f64>();
        let (mut xs, mut ys): (Vec<usize>, Vec<usize>) =
            worst.iter().map(|e| (e.1 % width, e.1 / width)).unzip();
        let quartiles = |v: &mut Vec<usize>| {
            v.sort_unstable();
            format!("{}-{}", v[v.len() / 4], v[3 * v.len() / 4])
        };
        println!(
            "| {} | {:.1}% | {} | {} |",
            scene.meshes[*geom as usize].name,
            100.0 * share,
            quartiles(&mut xs),
            quartiles(&mut ys)
        );
    }
    Ok(())
}
