//! `photondiff report` in a real browser: Debian's headless Chromium (installed here when
//! missing) loads the page from disk; every image must load, no error may reach the console,
//! the zoom must move every view together, and a screenshot must show content.

mod common;

use photondiff::reference::channels::ChannelImage;
use photondiff::reference::chart::{scatter_svg, Point};
use photondiff::render::film::Film;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const CHROMIUM: &str = "/usr/bin/chromium";

/// Installs Debian's chromium when missing; `false` (and a message) where packages cannot be
/// installed (not root and no password-less sudo).
fn ensure_chromium() -> bool {
    // The tests run in parallel: one installs, the others wait for it.
    static READY: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *READY.get_or_init(install_chromium)
}

fn install_chromium() -> bool {
    if Path::new(CHROMIUM).exists() {
        return true;
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let sudo = !root
        && Command::new("sudo")
            .args(["-n", "true"])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    if !root && !sudo {
        common::unavailable(&format!("{CHROMIUM} is missing and packages cannot be installed here (not root, no password-less sudo); install Debian's chromium package to run this test"));
        return false;
    }
    let apt = |args: &[&str]| {
        let mut c = if sudo {
            let mut c = Command::new("sudo");
            c.arg("apt-get");
            c
        } else {
            Command::new("apt-get")
        };
        c.args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status()
            .is_ok_and(|s| s.success())
    };
    eprintln!("installing Debian's chromium package for the browser test");
    assert!(apt(&["update", "-qq"]), "apt-get update failed");
    assert!(
        apt(&["install", "-y", "--no-install-recommends", "chromium"]),
        "apt-get install chromium failed"
    );
    assert!(Path::new(CHROMIUM).exists());
    true
}

/// Runs headless Chromium on `page` with `extra` flags in a process group of its own, waits
/// (at most two minutes), then kills that group (Chromium forks helpers). Returns stdout and
/// stderr.
fn chromium(page: &Path, work: &Path, extra: &[String]) -> (String, String) {
    let profile = tempfile::tempdir().unwrap();
    let (out, err) = (work.join("chromium.out"), work.join("chromium.err"));
    let mut child = Command::new(CHROMIUM)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .process_group(0)
        .spawn()
        .expect("start chromium");
    let group = child.id();
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if Instant::now() > deadline {
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    // Only the group this test created: the browser and the helpers it forked.
    let _ = Command::new("kill")
        .args(["-KILL", "--", &format!("-{group}")])
        .stderr(Stdio::null())
        .status();
    let _ = child.wait();
    let (out, err) = (
        std::fs::read_to_string(out).unwrap(),
        std::fs::read_to_string(err).unwrap(),
    );
    assert!(
        status.is_some(),
        "chromium did not finish in 2 minutes: {err}"
    );
    (out, err)
}

fn write_film(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> f64) {
    let mut film = Film::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = f(x, y);
            film.pixels[(y * w + x) as usize] = glam::DVec3::new(v, 0.8 * v, 0.6 * v);
        }
    }
    film.write_exr(path, &[]).unwrap();
}

/// A small report: a reference with a bright spot, two renders, a mask, a table, a chart.
fn make_report(dir: &Path) -> PathBuf {
    let (w, h) = (96, 64);
    let spot = |x: u32, y: u32| {
        let (dx, dy) = (x as f64 - 60.0, y as f64 - 30.0);
        0.2 + 0.002 * x as f64 + 3.0 * (-(dx * dx + dy * dy) / 40.0).exp()
    };
    write_film(&dir.join("ref.exr"), w, h, spot);
    write_film(&dir.join("blurry.exr"), w, h, |x, y| 0.9 * spot(x, y));
    write_film(&dir.join("noisy.exr"), w, h, |x, y| {
        spot(x, y) * if (x * 7 + y * 13) % 5 == 0 { 1.6 } else { 0.85 }
    });
    let mut mask = vec![0.0; (w * h) as usize];
    for y in 24..36 {
        for x in 52..68 {
            mask[(y * w + x) as usize] = 1.0;
        }
    }
    ChannelImage {
        width: w as usize,
        height: h as usize,
        names: vec!["Y".into()],
        planes: vec![mask],
    }
    .write_exr(&dir.join("spot.exr"))
    .unwrap();
    // A region whose box is the whole image: not cropped (the images show it).
    ChannelImage {
        width: w as usize,
        height: h as usize,
        names: vec!["Y".into()],
        planes: vec![vec![1.0; (w * h) as usize]],
    }
    .write_exr(&dir.join("everywhere.exr"))
    .unwrap();
    std::fs::write(
        dir.join("table.json"),
        r#"{"title": "Timing table", "columns": ["method", "time (s)", "relRMSE"],
            "rows": [["blurry", 0.5, 0.1], ["noisy", 0.25, 0.4]], "notes": ["one run"]}"#,
    )
    .unwrap();
    let chart = scatter_svg(
        "speed against error",
        "seconds",
        "relRMSE",
        &[
            Point {
                label: "blurry".into(),
                x: 0.5,
                y: 0.1,
            },
            Point {
                label: "noisy".into(),
                x: 0.25,
                y: 0.4,
            },
        ],
    );
    std::fs::write(dir.join("chart.svg"), chart).unwrap();
    let out = dir.join("report");
    let status = Command::new(env!("CARGO_BIN_EXE_photondiff"))
        .arg("report")
        .arg("--reference")
        .arg(dir.join("ref.exr"))
        .arg(dir.join("blurry.exr"))
        .arg(format!("noisy render={}", dir.join("noisy.exr").display()))
        .arg("--mask")
        .arg(dir.join("spot.exr"))
        .arg("--mask")
        .arg(dir.join("everywhere.exr"))
        .arg("--table")
        .arg(dir.join("table.json"))
        .arg("--chart")
        .arg(dir.join("chart.svg"))
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    out.join("index.html")
}

/// The report status line in a dumped DOM: (data-status, text).
fn status(dom: &str) -> (String, String) {
    let start = dom.find("id=\"status\"").expect("status line in the DOM");
    let tag_end = start + dom[start..].find('>').unwrap();
    let attrs = &dom[start..tag_end];
    let s = attrs.find("data-status=\"").unwrap() + 13;
    let value = attrs[s..s + attrs[s..].find('"').unwrap()].to_string();
    let text_end = tag_end + dom[tag_end..].find("</p>").unwrap();
    (value, dom[tag_end + 1..text_end].to_string())
}

/// Console messages Chromium logged (`--enable-logging=stderr`): the page logs nothing, so any
/// message (an uncaught exception, a console.error) is a failure.
fn console_messages(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.contains("CONSOLE")).collect()
}

#[test]
fn report_loads_cleanly_in_headless_chromium() {
    if !ensure_chromium() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let page = make_report(dir.path());
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "no network"
    );
    let images = html.matches("<img ").count();
    // 3 images + 2 error maps + colour bar + (3 images + 2 maps) crops of the spot + chart; none
    // of the region that covers the whole image.
    assert_eq!(images, 12);
    assert!(
        html.contains("<h3>everywhere (6144 px; its box, 96 x 64 at (0, 0), is most of the image: see the images above)</h3>"),
        "{html}"
    );

    let (dom, err) = chromium(&page, dir.path(), &["--dump-dom".into()]);
    assert_eq!(
        status(&dom),
        ("ok".to_string(), format!("All {images} images loaded.")),
        "{err}"
    );
    assert_eq!(console_messages(&err), Vec::<&str>::new());

    // Zoom one view with the wheel: every view follows with the same transform.
    let zoomed = page.with_file_name("zoom.html");
    let probe = r#"<script>window.addEventListener('load', function () {
      var v = document.querySelector('.view'), r = v.getBoundingClientRect();
      v.dispatchEvent(new WheelEvent('wheel', { deltaY: -100, clientX: r.left + 30,
        clientY: r.top + 20, bubbles: true, cancelable: true }));
      var t = Array.prototype.map.call(document.querySelectorAll('.view img'),
        function (i) { return i.style.transform; });
      var p = document.createElement('pre'); p.id = 'zoomtest'; p.textContent = t.join('|');
      document.body.appendChild(p); });</script></body>"#;
    std::fs::write(&zoomed, html.replace("</body>", probe)).unwrap();
    let (dom, err) = chromium(&zoomed, dir.path(), &["--dump-dom".into()]);
    let s = dom.find("<pre id=\"zoomtest\">").expect("zoom probe ran") + 19;
    let transforms: Vec<&str> = dom[s..s + dom[s..].find("</pre>").unwrap()]
        .split('|')
        .collect();
    assert_eq!(transforms.len(), 5, "{transforms:?}");
    assert!(transforms[0].contains("scale(1.25)"), "{transforms:?}");
    assert!(
        transforms.iter().all(|t| *t == transforms[0]),
        "{transforms:?}"
    );
    assert_eq!(console_messages(&err), Vec::<&str>::new());

    // A screenshot with content: many grey levels, not one flat colour.
    let shot = dir.path().join("shot.png");
    chromium(
        &page,
        dir.path(),
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,1600".into(),
        ],
    );
    let image = image::open(&shot).expect("screenshot written").into_luma8();
    assert_eq!(image.dimensions(), (1200, 1600));
    let n = image.pixels().len() as f64;
    let mean = image.pixels().map(|p| p.0[0] as f64).sum::<f64>() / n;
    let var = image
        .pixels()
        .map(|p| (p.0[0] as f64 - mean).powi(2))
        .sum::<f64>()
        / n;
    let mut levels = [false; 256];
    for p in image.pixels() {
        levels[p.0[0] as usize] = true;
    }
    let distinct = levels.iter().filter(|&&l| l).count();
    assert!(
        var > 100.0 && distinct > 50,
        "variance {var}, {distinct} grey levels"
    );
}

#[test]
fn a_missing_image_is_reported_by_the_page() {
    if !ensure_chromium() {
        return;
    }
    // The check itself can fail: remove one image and the page says so.
    let dir = tempfile::tempdir().unwrap();
    let page = make_report(dir.path());
    std::fs::remove_file(page.with_file_name("img").join("error-1.png")).unwrap();
    let (dom, _) = chromium(&page, dir.path(), &["--dump-dom".into()]);
    let (value, text) = status(&dom);
    assert_eq!(value, "error");
    assert!(text.contains("image not loaded: img/error-1.png"), "{text}");
    // And a console error reaches both the page's status and Chromium's console log.
    let html = std::fs::read_to_string(&page).unwrap();
    let probe = "<script>console.error('probe-error');</script></body>";
    std::fs::write(&page, html.replace("</body>", probe)).unwrap();
    let (dom, err) = chromium(&page, dir.path(), &["--dump-dom".into()]);
    assert!(status(&dom).1.contains("probe-error"), "{dom}");
    assert!(
        console_messages(&err)
            .iter()
            .any(|l| l.contains("probe-error")),
        "{err}"
    );
}
