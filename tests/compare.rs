//! `photondiff compare` on tiny EXRs written here: figures against values computed by hand,
//! masks, the error map's colours, every mismatch's exact message, `--max-relrmse`'s status.

mod common;

use photondiff::reference::channels::ChannelImage;
use std::path::{Path, PathBuf};
use std::process::Output;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_photondiff")
}

/// Writes a one-plane-per-channel EXR.
fn write(dir: &Path, name: &str, w: usize, h: usize, channels: &[(&str, Vec<f64>)]) -> PathBuf {
    let path = dir.join(name);
    ChannelImage {
        width: w,
        height: h,
        names: channels.iter().map(|c| c.0.to_string()).collect(),
        planes: channels.iter().map(|c| c.1.clone()).collect(),
    }
    .write_exr(&path)
    .unwrap();
    path
}

fn run(args: &[&Path]) -> Output {
    let mut c = std::process::Command::new(bin());
    c.arg("compare");
    for a in args {
        c.arg(a);
    }
    c.output().unwrap()
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn stderr(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(1), "expected exit status 1");
    String::from_utf8(out.stderr.clone()).unwrap()
}

fn close(v: &serde_json::Value, expected: f64) {
    let x = v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"));
    assert!((x - expected).abs() < 1e-9, "{x} != {expected}");
}

/// R = [1 2; 3 2], I = [1 3; 2 2] (one channel Y). I - R = [0 1; -1 0].
fn pair(dir: &Path) -> (PathBuf, PathBuf) {
    let i = write(dir, "i.exr", 2, 2, &[("Y", vec![1.0, 3.0, 2.0, 2.0])]);
    let r = write(dir, "r.exr", 2, 2, &[("Y", vec![1.0, 2.0, 3.0, 2.0])]);
    (i, r)
}

#[test]
fn figures_match_hand_computed_values() {
    let d = tempfile::tempdir().unwrap();
    let (i, r) = pair(d.path());
    let v = json(&run(&[&i, &r, Path::new("--json")]));
    let region = &v["regions"][0];
    assert_eq!(region["name"], "image");
    assert_eq!(region["pixels"], 4);
    // MSE = (0 + 1 + 1 + 0) / 4 = 0.5, mean(R) = 2, peak = 3.
    close(&region["rmse"], 0.5f64.sqrt());
    close(&region["rel_rmse"], 0.5f64.sqrt() / 2.0);
    close(&region["psnr_db"], 10.0 * 18f64.log10());
    close(&region["peak"], 3.0);
    close(&region["mean_ratio"], 1.0);
    // A 2 x 2 image holds no 8 x 8 window.
    assert!(region["ssim"].is_null());
    assert_eq!(v["channels"], serde_json::json!(["Y"]));

    // The text table carries the same figures.
    let out = run(&[&i, &r]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let row = text.lines().find(|l| l.starts_with("image ")).unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cells[1..4], ["4", "0.35355", "7.07107e-1"]);
    assert_eq!(cells[4..7], ["12.55", "1.00000", "-"]);
}

#[test]
fn masks_are_measured_each_by_name() {
    let d = tempfile::tempdir().unwrap();
    let (i, r) = pair(d.path());
    // Any channel above zero counts; negative values and zeros do not.
    let a = write(
        d.path(),
        "diag.exr",
        2,
        2,
        &[
            ("G", vec![0.0, 0.0, 1.0, 0.0]),
            ("R", vec![-1.0, 0.5, 0.0, 0.0]),
        ],
    );
    let b = write(
        d.path(),
        "top.exr",
        2,
        2,
        &[("Y", vec![1.0, 2.0, 0.0, 0.0])],
    );
    let v = json(&run(&[
        &i,
        &r,
        Path::new("--mask"),
        &a,
        Path::new("--mask"),
        &b,
        Path::new("--json"),
    ]));
    let regions = v["regions"].as_array().unwrap();
    assert_eq!(regions.len(), 2);
    // diag: pixels 1 and 2: I - R = 1, -1; mean(R) = 2.5; peak 3; mean ratio 5 / 5.
    assert_eq!(regions[0]["name"], "diag");
    assert_eq!(regions[0]["pixels"], 2);
    close(&regions[0]["rel_rmse"], 0.4);
    close(&regions[0]["rmse"], 1.0);
    close(&regions[0]["psnr_db"], 10.0 * 9f64.log10());
    close(&regions[0]["mean_ratio"], 1.0);
    // top: pixels 0 and 1: I - R = 0, 1; mean(R) = 1.5; peak 2; mean ratio 4 / 3.
    assert_eq!(regions[1]["name"], "top");
    close(&regions[1]["rel_rmse"], 0.5f64.sqrt() / 1.5);
    close(&regions[1]["psnr_db"], 10.0 * 8f64.log10());
    close(&regions[1]["mean_ratio"], 4.0 / 3.0);

    // --max-relrmse: 0.4 is not exceeded by diag (exactly 0.4) but is by top (0.4714).
    let out = run(&[
        &i,
        &r,
        Path::new("--mask"),
        &a,
        Path::new("--mask"),
        &b,
        Path::new("--max-relrmse"),
        Path::new("0.4"),
    ]);
    assert_eq!(
        stderr(&out),
        "photondiff: error: relRMSE exceeds --max-relrmse 0.4 over top (0.47140)\n"
    );
    let out = run(&[
        &i,
        &r,
        Path::new("--mask"),
        &a,
        Path::new("--max-relrmse"),
        Path::new("0.4"),
    ]);
    assert!(out.status.success());
    // Two masks of one name (in two folders) would be two rows of one name.
    let sub = d.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::copy(&b, sub.join("diag.exr")).unwrap();
    let out = run(&[
        &i,
        &r,
        Path::new("--mask"),
        &a,
        Path::new("--mask"),
        &sub.join("diag.exr"),
    ]);
    assert_eq!(
        stderr(&out),
        "photondiff: error: two masks are named 'diag' (a mask is named by its file name \
         without the extension): rename one\n"
    );
    let out = run(&[&i, &r, Path::new("--max-relrmse"), Path::new("0.3")]);
    assert_eq!(
        stderr(&out),
        "photondiff: error: relRMSE exceeds --max-relrmse 0.3 over image (0.35355)\n"
    );
    assert!(
        run(&[&i, &r, Path::new("--max-relrmse"), Path::new("0.36")])
            .status
            .success()
    );
}

#[test]
fn ssim_psnr_and_alpha_on_rgb_images() {
    let d = tempfile::tempdir().unwrap();
    let n = 64;
    // 8 x 8: one SSIM window. Reference white (sRGB luminance 1), image black (0):
    // SSIM = (2 * 0 * 1 + c1)(0 + c2) / ((0 + 1 + c1)(0 + 0 + c2)) = c1 / (1 + c1), c1 = 1e-4.
    // Alpha differs wildly and is not measured.
    let r = write(
        d.path(),
        "r.exr",
        8,
        8,
        &[
            ("A", vec![1.0; n]),
            ("B", vec![1.0; n]),
            ("G", vec![1.0; n]),
            ("R", vec![1.0; n]),
        ],
    );
    let i = write(
        d.path(),
        "i.exr",
        8,
        8,
        &[
            ("A", vec![100.0; n]),
            ("B", vec![0.0; n]),
            ("G", vec![0.0; n]),
            ("R", vec![0.0; n]),
        ],
    );
    let v = json(&run(&[&i, &r, Path::new("--json")]));
    let region = &v["regions"][0];
    close(&region["ssim"], 1e-4 / (1.0 + 1e-4));
    close(&region["rel_rmse"], 1.0);
    close(&region["mean_ratio"], 0.0);
    close(&region["psnr_db"], 0.0);
    assert_eq!(v["measured_channels"], serde_json::json!(["B", "G", "R"]));
    // An image against itself: relRMSE 0, SSIM 1, PSNR infinite (null).
    let v = json(&run(&[&r, &r, Path::new("--json")]));
    close(&v["regions"][0]["rel_rmse"], 0.0);
    close(&v["regions"][0]["ssim"], 1.0);
    assert!(v["regions"][0]["psnr_db"].is_null());
}

#[test]
fn error_map_colours_and_colour_bar() {
    let d = tempfile::tempdir().unwrap();
    let (i, r) = pair(d.path());
    let png = d.path().join("maps/err.png");
    let m = write(d.path(), "m.exr", 2, 2, &[("Y", vec![1.0, 1.0, 0.0, 0.0])]);
    let out = run(&[
        &i,
        &r,
        Path::new("--error-map"),
        &png,
        Path::new("--error-map-max"),
        Path::new("1"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let map = image::open(&png).unwrap().into_rgb8();
    // The image, then the colour bar's panel; at least 180 pixels tall for the labels.
    assert_eq!(map.dimensions(), (2 + 104, 180));
    // Per-pixel error |I - R| / mean(R): 0 at pixel 0 (viridis bottom), 0.5 at pixel 1
    // (viridis middle) on a scale to 1.
    assert_eq!(map.get_pixel(0, 0).0, [68, 1, 84]);
    assert_eq!(map.get_pixel(1, 0).0, [33, 144, 141]);
    // The bar's top is the top colour, its bottom the bottom colour.
    assert_eq!(map.get_pixel(2 + 12 + 8, 28).0, [253, 231, 37]);
    assert_eq!(map.get_pixel(2 + 12 + 8, 180 - 12).0, [68, 1, 84]);
    // Labels: white text somewhere right of the bar.
    let labelled = (2 + 36..2 + 104)
        .flat_map(|x| (0..180).map(move |y| (x, y)))
        .filter(|&(x, y)| map.get_pixel(x, y).0.iter().all(|&c| c > 200))
        .count();
    assert!(labelled > 20, "{labelled} white label pixels");
    // With a mask, pixels outside it are grey.
    let out = run(&[
        &i,
        &r,
        Path::new("--mask"),
        &m,
        Path::new("--error-map"),
        &png,
    ]);
    assert!(out.status.success());
    let map = image::open(&png).unwrap().into_rgb8();
    assert_eq!(map.get_pixel(0, 1).0, [72, 72, 72]);
    assert_eq!(map.get_pixel(1, 1).0, [72, 72, 72]);
    // Default scale top: the 99th percentile of the masked errors (0 and 0.5), i.e. 0.5.
    assert_eq!(map.get_pixel(1, 0).0, [253, 231, 37]);
}

#[test]
fn mismatches_are_one_line_errors() {
    let d = tempfile::tempdir().unwrap();
    let (i, r) = pair(d.path());
    let p = |s: &Path| s.display().to_string();
    let wide = write(d.path(), "wide.exr", 3, 2, &[("Y", vec![0.0; 6])]);
    assert_eq!(
        stderr(&run(&[&i, &wide])),
        format!(
            "photondiff: error: {} is 2 x 2 pixels but the reference {} is 3 x 2\n",
            p(&i),
            p(&wide)
        )
    );
    let rgb = write(
        d.path(),
        "rgb.exr",
        2,
        2,
        &[
            ("B", vec![0.0; 4]),
            ("G", vec![0.0; 4]),
            ("R", vec![0.0; 4]),
        ],
    );
    assert_eq!(
        stderr(&run(&[&i, &rgb])),
        format!(
            "photondiff: error: {} has channels Y but the reference {} has channels B,G,R\n",
            p(&i),
            p(&rgb)
        )
    );
    let small = write(d.path(), "small.exr", 1, 2, &[("Y", vec![1.0; 2])]);
    assert_eq!(
        stderr(&run(&[&i, &r, Path::new("--mask"), &small])),
        format!(
            "photondiff: error: mask {} is 1 x 2 pixels but the images are 2 x 2\n",
            p(&small)
        )
    );
    let empty = write(
        d.path(),
        "empty.exr",
        2,
        2,
        &[("Y", vec![0.0, -1.0, 0.0, 0.0])],
    );
    assert_eq!(
        stderr(&run(&[&i, &r, Path::new("--mask"), &empty])),
        format!(
            "photondiff: error: mask {} selects no pixel (no value above 0)\n",
            p(&empty)
        )
    );
    let nan = write(
        d.path(),
        "nan.exr",
        2,
        2,
        &[("Y", vec![0.0, 0.0, f64::NAN, 0.0])],
    );
    assert_eq!(
        stderr(&run(&[&nan, &r])),
        format!(
            "photondiff: error: {}: channel Y of pixel (0, 1) is not finite (NaN)\n",
            p(&nan)
        )
    );
    // As a mask: NaN is above nothing, and its pixel was left out of the region silently.
    assert_eq!(
        stderr(&run(&[&i, &r, Path::new("--mask"), &nan])),
        format!(
            "photondiff: error: {}: channel Y of pixel (0, 1) is not finite (NaN)\n",
            p(&nan)
        )
    );
    let missing = d.path().join("missing.exr");
    assert_eq!(
        stderr(&run(&[&i, &missing])),
        format!(
            "photondiff: error: {}: cannot open: No such file or directory (os error 2)\n",
            p(&missing)
        )
    );
    let junk = d.path().join("junk.exr");
    std::fs::write(&junk, b"not an image at all").unwrap();
    let e = stderr(&run(&[&junk, &r]));
    assert!(
        e.starts_with(&format!(
            "photondiff: error: {}: cannot read EXR: ",
            p(&junk)
        )),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
    // A reference that is black where measured: relRMSE undefined, so no threshold can pass.
    let black = write(d.path(), "black.exr", 2, 2, &[("Y", vec![0.0; 4])]);
    assert_eq!(
        stderr(&run(&[&i, &black, Path::new("--max-relrmse"), Path::new("1")])),
        "photondiff: error: relRMSE over image is undefined (the reference's mean is 0) and cannot be checked against --max-relrmse 1\n"
    );
}

/// `report` refuses what `compare` refuses (a NaN pixel made a NaN table), and an exposure
/// that is not a number of stops (the page said "radiance x 2^NaN").
#[test]
fn report_refuses_non_finite_images_and_exposures() {
    let d = tempfile::tempdir().unwrap();
    let rgb = |v: [f64; 4]| [("R", v.to_vec()), ("G", v.to_vec()), ("B", v.to_vec())];
    let r = write(d.path(), "ref.exr", 2, 2, &rgb([1.0; 4]));
    let nan = write(d.path(), "nan.exr", 2, 2, &rgb([1.0, 1.0, f64::NAN, 1.0]));
    let out = d.path().join("report");
    let report = |extra: &[&str], render: &Path| {
        std::process::Command::new(bin())
            .arg("report")
            .arg("--reference")
            .arg(&r)
            .arg(render)
            .arg("-o")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap()
    };
    assert_eq!(
        stderr(&report(&[], &nan)),
        format!(
            "photondiff: error: {}: pixel (0, 1) is not finite ([NaN, NaN, NaN])\n",
            nan.display()
        )
    );
    for (value, shown) in [("nan", "NaN"), ("1e300", "1e300"), ("-65", "-65")] {
        assert_eq!(
            stderr(&report(&["--exposure", value], &r)),
            format!(
                "photondiff: error: --exposure must be a number of stops in [-64, 64], got {shown}\n"
            )
        );
    }
    // Two renders of one caption could not be told apart on the page.
    let same = format!("a={}", r.display());
    assert_eq!(
        stderr(&report(&[same.as_str()], Path::new(&same))),
        "photondiff: error: two renders are captioned 'a': caption them apart (LABEL=FILE.exr)\n"
    );
    // Two masks of one name, likewise.
    let mask = write(d.path(), "m.exr", 2, 2, &rgb([1.0; 4]));
    let (m1, m2) = (
        format!("x={}", mask.display()),
        format!("x={}", r.display()),
    );
    assert_eq!(
        stderr(&report(&["--mask", &m1, "--mask", &m2], &r)),
        "photondiff: error: two regions are named 'x': name the masks apart (NAME=M.exr)\n"
    );
    // NAME=M.exr names a mask (the mask was read from the whole argument, which is no file).
    let named = report(&["--mask", &m1], &r);
    assert!(named.status.success(), "{}", stderr(&named));
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains(">x<"), "the region x is not on the page");
    std::fs::remove_dir_all(&out).unwrap();
    // A caption with no file after it is named as such (the message named the file "").
    assert_eq!(
        stderr(&report(&[], Path::new("x="))),
        "photondiff: error: \"x=\": no file after '=' (LABEL=FILE.exr)\n"
    );
    // A chart is shown as an image: a scene file given as one is refused (it was copied and
    // showed as a broken image).
    let toml = d.path().join("scene.toml");
    std::fs::write(&toml, "[camera]\n").unwrap();
    let chart = toml.to_str().unwrap();
    assert_eq!(
        stderr(&report(&["--chart", chart], &r)),
        format!(
            "photondiff: error: {}: a chart must be an SVG or PNG file (.svg, .png)\n",
            toml.display()
        )
    );
    assert!(!out.exists());
    // A chart a report wrote into the folder before, given again: copied onto itself, it was
    // emptied; two such charts swap places whole.
    let (first, second) = (d.path().join("a.svg"), d.path().join("b.svg"));
    std::fs::write(&first, "<svg>a</svg>").unwrap();
    std::fs::write(&second, "<svg>bb</svg>").unwrap();
    let charts = [
        "--chart",
        first.to_str().unwrap(),
        "--chart",
        second.to_str().unwrap(),
    ];
    assert!(report(&charts, &r).status.success());
    let (zero, one) = (out.join("img/chart-0.svg"), out.join("img/chart-1.svg"));
    let swapped = [
        "--chart",
        one.to_str().unwrap(),
        "--chart",
        zero.to_str().unwrap(),
    ];
    let again = report(&swapped, &r);
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(std::fs::read_to_string(&zero).unwrap(), "<svg>bb</svg>");
    assert_eq!(std::fs::read_to_string(&one).unwrap(), "<svg>a</svg>");
}

/// Two tiles of one size from other places of the image are not compared as the same pixels
/// (the data window's offset was ignored), by `compare` nor by `report` (which compared them,
/// relRMSE 4.32), nor a mask from another place of the image.
#[test]
fn tiles_from_other_places_are_not_compared() {
    use photondiff::render::film::Film;
    let d = tempfile::tempdir().unwrap();
    let film = Film::new(2, 2);
    let (left, right) = (d.path().join("left.exr"), d.path().join("right.exr"));
    film.write_exr_window(&left, &[], (0, 0), (4, 2)).unwrap();
    film.write_exr_window(&right, &[], (2, 0), (4, 2)).unwrap();
    assert_eq!(
        stderr(&run(&[&left, &right])),
        format!(
            "photondiff: error: {} starts at pixel (0, 0) of its image but {} at (2, 0): not the same pixels\n",
            left.display(),
            right.display()
        )
    );
    assert!(run(&[&right, &right]).status.success());
    let refused = format!(
        "photondiff: error: {} starts at pixel (2, 0) of its image but {} at (0, 0): not the \
         same pixels\n",
        right.display(),
        left.display()
    );
    let mask = [&left, &left, Path::new("--mask"), &right];
    assert_eq!(stderr(&run(&mask)), refused);
    let page = d.path().join("page");
    let report = |args: &[&std::ffi::OsStr]| {
        std::process::Command::new(bin())
            .arg("report")
            .args(args)
            .arg("-o")
            .arg(&page)
            .output()
            .unwrap()
    };
    let with_render = format!("a={}", right.display());
    let out = report(&[
        "--reference".as_ref(),
        left.as_os_str(),
        with_render.as_ref(),
    ]);
    assert_eq!(stderr(&out), refused);
    let with_mask = format!("m={}", right.display());
    let out = report(&[
        "--reference".as_ref(),
        left.as_os_str(),
        format!("a={}", left.display()).as_ref(),
        "--mask".as_ref(),
        with_mask.as_ref(),
    ]);
    assert_eq!(stderr(&out), refused);
}

/// An error map is not written over a folder or over the images compared.
#[test]
fn the_error_map_needs_a_file_of_its_own() {
    let d = tempfile::tempdir().unwrap();
    let (i, r) = pair(d.path());
    let out = |map: &Path| {
        std::process::Command::new(bin())
            .arg("compare")
            .arg(&i)
            .arg(&r)
            .arg("--error-map")
            .arg(map)
            .output()
            .unwrap()
    };
    assert_eq!(
        stderr(&out(d.path())),
        format!(
            "photondiff: error: --error-map: {} is a folder\n",
            d.path().display()
        )
    );
    assert_eq!(
        stderr(&out(&r)),
        format!(
            "photondiff: error: --error-map names the reference ({}): the run would overwrite it\n",
            r.display()
        )
    );
    // A scale without the map it scales is refused (it was ignored).
    let run = std::process::Command::new(bin())
        .arg("compare")
        .arg(&i)
        .arg(&r)
        .args(["--error-map-max", "0.5"])
        .output()
        .unwrap();
    assert_eq!(
        stderr(&run),
        "photondiff: error: --error-map-max sets the error map's scale: it needs --error-map\n"
    );
    // A PNG whatever the name: `image` chose the format from the extension and truncated an
    // existing `map.jpg` before refusing it.
    for name in ["map.jpg", "map"] {
        let map = d.path().join(name);
        std::fs::write(&map, "old").unwrap();
        let run = out(&map);
        assert!(run.status.success(), "{name}: {}", stderr(&run));
        let bytes = std::fs::read(&map).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{name}");
        assert!(image::load_from_memory(&bytes).is_ok(), "{name}");
    }
}

/// Against a reference that is zero everywhere, the error map shows absolute errors and says
/// so, on stderr and in the colour bar's title (it used to be titled "relative error").
#[test]
fn an_all_zero_reference_gives_an_absolute_error_map() {
    let d = tempfile::tempdir().unwrap();
    // The relative map of i against r (mean 1.5) and the absolute map of e against zero, on
    // one scale: their colour bars differ in the title only.
    let i = write(d.path(), "i.exr", 2, 2, &[("Y", vec![1.0, 1.5, 2.0, 2.25])]);
    let r = write(d.path(), "r.exr", 2, 2, &[("Y", vec![1.0, 1.0, 2.0, 2.0])]);
    let z = write(d.path(), "z.exr", 2, 2, &[("Y", vec![0.0; 4])]);
    let e = write(d.path(), "e.exr", 2, 2, &[("Y", vec![0.0, 0.5, 0.0, 0.25])]);
    let (relative, absolute) = (d.path().join("rel.png"), d.path().join("abs.png"));
    let scale = [Path::new("--error-map-max"), Path::new("0.5")];
    let out = run(&[
        &i,
        &r,
        Path::new("--error-map"),
        &relative,
        scale[0],
        scale[1],
    ]);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("note"));
    let out = run(&[
        &e,
        &z,
        Path::new("--error-map"),
        &absolute,
        scale[0],
        scale[1],
    ]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "photondiff: note: the reference is zero everywhere: the error map shows absolute \
         errors (RMS over channels of I - R)"
    );
    let (rel, abs) = (
        image::open(&relative).unwrap().into_rgb8(),
        image::open(&absolute).unwrap().into_rgb8(),
    );
    // The absolute map holds the errors themselves: 0.5 is the top colour, 0.25 the middle.
    assert_eq!(abs.get_pixel(1, 0).0, [253, 231, 37]);
    assert_eq!(abs.get_pixel(1, 1).0, [33, 144, 141]);
    // The titles (the panel's top 20 rows) differ, the ticks below do not.
    let differ = |y0: u32, y1: u32| {
        (2..2 + 104)
            .flat_map(|x| (y0..y1).map(move |y| (x, y)))
            .filter(|&(x, y)| rel.get_pixel(x, y) != abs.get_pixel(x, y))
            .count()
    };
    assert!(differ(0, 20) > 20, "{}", differ(0, 20));
    assert_eq!(differ(24, 180), 0);
}

/// The header of an uncompressed scanline EXR of `w` x `h` pixels of three f32 channels.
fn exr_header(w: i32, h: i32) -> Vec<u8> {
    let attribute = |name: &str, kind: &str, data: &[u8]| {
        let mut a = [name.as_bytes(), b"\0", kind.as_bytes(), b"\0"].concat();
        a.extend((data.len() as i32).to_le_bytes());
        a.extend(data);
        a
    };
    let mut channels = Vec::new();
    for c in ["B", "G", "R"] {
        channels.extend(c.as_bytes());
        channels.push(0);
        channels.extend(2i32.to_le_bytes()); // f32
        channels.extend([0, 0, 0, 0]);
        channels.extend(1i32.to_le_bytes());
        channels.extend(1i32.to_le_bytes());
    }
    channels.push(0);
    let window: Vec<u8> = [0, 0, w - 1, h - 1]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    out.extend(attribute("channels", "chlist", &channels));
    out.extend(attribute("compression", "compression", &[0]));
    out.extend(attribute("dataWindow", "box2i", &window));
    out.extend(attribute("displayWindow", "box2i", &window));
    out.extend(attribute("lineOrder", "lineOrder", &[0]));
    out.extend(attribute("pixelAspectRatio", "float", &1f32.to_le_bytes()));
    out.extend(attribute("screenWindowCenter", "v2f", &[0; 8]));
    out.extend(attribute("screenWindowWidth", "float", &1f32.to_le_bytes()));
    out.push(0);
    out
}

/// Files whose header claims more pixels than they hold are refused before the reader
/// allocates them (a 462-byte file made it ask for 6.4 GB and abort under a memory limit; a
/// 240 KB one whose offset table pointed every line at the same bytes grew to 20 GB). Run
/// under a 3 GB address-space limit, so that the allocation fails here rather than filling
/// the machine.
#[test]
fn exr_headers_claiming_more_than_the_file_holds_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let small = d.path().join("claims.exr");
    std::fs::write(&small, [exr_header(40000, 40000), vec![0; 128]].concat()).unwrap();
    let shared = d.path().join("shared.exr");
    let header = exr_header(20000, 20000);
    let mut bytes = header.clone();
    let line = (header.len() + 8 * 20000) as u64;
    (0..20000).for_each(|_| bytes.extend(line.to_le_bytes()));
    bytes.extend(0i32.to_le_bytes());
    bytes.extend(240000i32.to_le_bytes());
    bytes.extend(vec![0; 240000]);
    std::fs::write(&shared, &bytes).unwrap();
    for (file, w, h) in [(&small, 40000, 40000), (&shared, 20000, 20000)] {
        let out = std::process::Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -v 3000000; exec '{}' compare '{1}' '{1}'",
                bin(),
                file.display()
            ))
            .output()
            .unwrap();
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            format!(
                "photondiff: error: {}: its header claims {w} x {h} pixels of 3 channels ({} bytes), more than a file of {} bytes can hold: the file is damaged or not an image\n",
                file.display(),
                w as u64 * h as u64 * 12,
                std::fs::metadata(file).unwrap().len()
            )
        );
        assert_eq!(out.status.code(), Some(1));
    }
}

/// Standard output whose reader has gone (`compare a b | head -1`) is dropped, not a panic
/// with a backtrace and status 101; one that cannot be written (a full disk under
/// `> results.txt`) is the run's error, status 1.
#[test]
fn a_closed_pipe_is_no_panic_and_a_full_disk_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let (image, reference) = pair(dir.path());
    // A pipe whose reading end is closed before the run starts: every write fails.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = std::process::Command::new(bin())
        .arg("compare")
        .args([&image, &reference])
        .stdout(writer)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!((out.status.code(), said.as_ref()), (Some(0), ""));
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = std::process::Command::new(bin())
        .arg("compare")
        .args([&image, &reference])
        .stdout(full)
        .output()
        .unwrap();
    assert_eq!(
        stderr(&out),
        "photondiff: error: standard output: cannot write: No space left on device (os error 28)\n"
    );
}

/// Standard error that cannot be written (its reader gone, `2>/dev/full`) drops the messages,
/// not the run: a render's stage messages and statistics panicked there (status 101), and
/// the image was never written.
#[test]
fn a_render_whose_standard_error_fails_still_writes_its_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, common::SMALL_SCENE).unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let sinks: [std::process::Stdio; 2] = [writer.into(), full.into()];
    for (k, sink) in sinks.into_iter().enumerate() {
        let exr = dir.path().join(format!("img{k}.exr"));
        let out = std::process::Command::new(bin())
            .args(["render", "--threads", "1", "--passes", "2", "-o"])
            .arg(&exr)
            .arg(&scene)
            .stderr(sink)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "sink {k}");
        assert!(
            exr.exists() && exr.with_extension("png").exists(),
            "sink {k}"
        );
    }
}

/// An output written to standard output is all standard output carries: `--stats-json
/// /dev/stdout` was followed by the `wrote ...` line, and no longer read as JSON.
#[test]
fn an_output_on_standard_output_is_not_followed_by_messages() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, common::SMALL_SCENE).unwrap();
    let out = std::process::Command::new(bin())
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "--stats-json",
            "/dev/stdout",
            "-o",
        ])
        .arg(dir.path().join("img.exr"))
        .arg(&scene)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["threads"], 1);
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("wrote "));
}

/// A render and a reference that name different scenes (`photondiff/scene_hash`) are compared,
/// since that may be meant, but with a warning on standard error (and, in `report`, on the
/// page): before, nothing showed that the figures compared two scenes.
#[test]
fn images_of_different_scenes_are_compared_with_a_warning() {
    use photondiff::render::film::Film;
    let d = tempfile::tempdir().unwrap();
    let mut film = Film::new(2, 2);
    film.pixels.fill(glam::DVec3::ONE);
    let tagged = |name: &str, hash: Option<&str>| {
        let path = d.path().join(name);
        let meta: Vec<(String, String)> = hash
            .map(|h| ("photondiff/scene_hash".to_string(), h.to_string()))
            .into_iter()
            .collect();
        film.write_exr_window(&path, &meta, (0, 0), (2, 2)).unwrap();
        path
    };
    let a = tagged("a.exr", Some("00000000000000aa"));
    let a2 = tagged("a2.exr", Some("00000000000000aa"));
    let b = tagged("b.exr", Some("00000000000000bb"));
    let untagged = tagged("plain.exr", None);
    let warning = format!(
        "photondiff: warning: {} and {} are of different scenes (photondiff/scene_hash \
         00000000000000bb and 00000000000000aa): the figures compare two scenes\n",
        b.display(),
        a.display()
    );
    let out = run(&[&b, &a]);
    assert!(out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stderr), warning);
    for (image, reference) in [(&a2, &a), (&untagged, &a), (&b, &untagged)] {
        let out = run(&[image, reference]);
        assert!(out.status.success());
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            "",
            "{image:?} {reference:?}"
        );
    }
    let page = d.path().join("page");
    let (same, other) = (
        format!("same={}", a2.display()),
        format!("other={}", b.display()),
    );
    let reference: [&std::ffi::OsStr; 2] = ["--reference".as_ref(), a.as_os_str()];
    let out = common::run_ok(["report".as_ref()].into_iter().chain(reference).chain([
        same.as_ref(),
        other.as_ref(),
        "-o".as_ref(),
        page.as_os_str(),
    ]));
    assert_eq!(String::from_utf8_lossy(&out.stderr), warning);
    let html = std::fs::read_to_string(page.join("index.html")).unwrap();
    assert_eq!(html.matches("are of different scenes").count(), 1);
}
