//! `rtmesh optimize` as users and farm scripts run it: a folder with good and bad
//! files, JSON lines, the mirrored output tree, a folder it cannot write, and the HTML
//! report opened in a real headless browser (Debian's `chromium`) under the report's
//! Content-Security-Policy.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn rtmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rtmesh"))
        .args(args)
        .output()
        .expect("run rtmesh")
}

/// `rtmesh optimize INPUT -o OUTPUT EXTRA...`.
fn optimize(input: &Path, output: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "optimize",
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    rtmesh(&args)
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rtmesh-optimize-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

const QUADS: &str =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nf 1 2 3\nf 1 3 4\nf 2 5 6\nf 2 6 3\n";

#[test]
fn a_batch_reports_bad_files_and_finishes_the_good_ones() {
    let dir = temp_dir("batch");
    let input = dir.join("in");
    std::fs::create_dir_all(input.join("sub")).unwrap();
    std::fs::write(input.join("good.obj"), QUADS).unwrap();
    std::fs::write(input.join("sub/also-good.obj"), QUADS).unwrap();
    std::fs::write(input.join("empty.obj"), "").unwrap();
    std::fs::write(input.join("broken.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    std::fs::write(
        input.join("nan.obj"),
        "v nan 0 0\nv 0 nan 0\nv 0 0 nan\nf 1 2 3\n",
    )
    .unwrap();
    let output = dir.join("out");
    let out = optimize(
        &input,
        &output,
        &["--json", "--size", "32x32", "--runs", "1"],
    );
    assert_eq!(out.status.code(), Some(1), "a failed file fails the run");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("3 of 5 files failed"), "{stderr}");
    assert!(stderr.contains("tris in"), "the summary table: {stderr}");
    let reports = lines(&out);
    assert_eq!(reports.len(), 5);
    let by_name = |name: &str| {
        reports
            .iter()
            .find(|r| r["input"].as_str().unwrap().ends_with(name))
            .unwrap_or_else(|| panic!("{name}"))
    };
    for good in ["in/good.obj", "sub/also-good.obj"] {
        let r = by_name(good);
        assert_eq!(r["ok"], true, "{r}");
        for key in [
            "input",
            "output",
            "report",
            "ok",
            "error",
            "seconds",
            "triangles_in",
            "triangles_out",
            "pair_ratio",
            "same_hits",
            "repairs",
            "before",
            "after",
        ] {
            assert!(r.get(key).is_some(), "{good}: no {key}");
        }
        assert_eq!(r["pair_ratio"], 1.0);
        for workload in ["primary", "diffuse", "shadow"] {
            for key in ["box_tests_per_ray", "tri_tests_per_ray", "mrays_per_s"] {
                assert!(r["after"][workload][key].is_number(), "{workload} {key}");
            }
        }
        assert!(r["after"]["bvh_bytes"].as_u64().unwrap() > 0);
    }
    // The tree is mirrored, with the pair lists beside the meshes.
    assert!(output.join("good.obj").is_file());
    assert!(output.join("sub/also-good.obj").is_file());
    let pairs: serde_json::Value =
        serde_json::from_slice(&std::fs::read(output.join("good.obj.pairs.json")).unwrap())
            .unwrap();
    assert_eq!(
        pairs["primitives"][0]["trianglePairIndices"],
        serde_json::json!([0, 1, 2, 3])
    );
    let error = |name: &str| by_name(name)["error"].as_str().unwrap().to_owned();
    assert!(
        error("broken.obj").contains("broken.obj:3:"),
        "{}",
        error("broken.obj")
    );
    assert!(
        error("empty.obj").contains("empty.obj"),
        "{}",
        error("empty.obj")
    );
    assert!(
        error("nan.obj").contains("nothing to trace"),
        "{}",
        error("nan.obj")
    );
    assert!(!output.join("broken.obj").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_output_folder_it_cannot_write_is_a_clear_error() {
    let dir = temp_dir("readonly");
    let mesh = dir.join("quads.obj");
    std::fs::write(&mesh, QUADS).unwrap();
    let locked = dir.join("locked");
    std::fs::create_dir_all(&locked).unwrap();
    let mut permissions = std::fs::metadata(&locked).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut permissions, 0o555);
    std::fs::set_permissions(&locked, permissions).unwrap();
    // Root writes into any folder; sysfs refuses new files even to root.
    let probe = locked.join("probe");
    let target = if std::fs::write(&probe, "").is_ok() {
        std::fs::remove_file(&probe).ok();
        PathBuf::from("/sys/rtmesh-cannot-write-here")
    } else {
        locked.clone()
    };
    let output = target.join("quads.obj");
    let out = optimize(&mesh, &output, &["--size", "0x0"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(target.to_str().unwrap()), "{stderr}");
    // --dry-run writes nothing, so it succeeds there.
    let dry = rtmesh(&[
        "optimize",
        mesh.to_str().unwrap(),
        "--dry-run",
        "--size",
        "0x0",
    ]);
    assert!(
        dry.status.success(),
        "{}",
        String::from_utf8_lossy(&dry.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `chromium` (or `$RTMESH_CHROMIUM`), when installed; CI requires it
/// (`RTMESH_REQUIRE_BROWSER=1`).
fn chromium() -> Option<PathBuf> {
    let candidate = std::env::var_os("RTMESH_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("chromium"));
    let found = Command::new(&candidate)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if found {
        return Some(candidate);
    }
    if std::env::var("RTMESH_REQUIRE_BROWSER").is_ok_and(|v| v == "1") {
        panic!(
            "RTMESH_REQUIRE_BROWSER=1 but {} does not run",
            candidate.display()
        );
    }
    eprintln!("note: no chromium; the browser test is skipped (apt-get install chromium)");
    None
}

/// Run headless chromium on `page`: (the DOM, the browser's log).
fn headless(chromium: &Path, page: &Path, extra: &[&str]) -> (String, String) {
    let url = format!("file://{}", page.display());
    let out = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .args(extra)
        .arg(&url)
        .output()
        .expect("run chromium");
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_report_opens_in_a_headless_browser_and_is_self_contained() {
    let Some(chromium) = chromium() else { return };
    let dir = temp_dir("browser");
    let report = dir.join("room.html");
    let out = rtmesh(&[
        "optimize",
        "builtin:room",
        "-o",
        dir.join("room.glb").to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--size",
        "128x128",
        "--runs",
        "1",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (dom, log) = headless(&chromium, &report, &["--dump-dom"]);
    for text in [
        "<h1>rtmesh optimize: builtin:room</h1>",
        "Same first hits",
        "One colour scale for both",
        "input SHA-256",
        "Findings",
        "Geometries",
        "pair box / triangle boxes",
    ] {
        assert!(dom.contains(text), "the page lacks {text:?}");
    }
    assert!(dom.matches("<img src=\"data:image/png;base64,").count() >= 4);
    assert!(dom.matches("<svg").count() >= 3);
    // The embedded report reads back.
    let start = dom.find("id=\"report\">").expect("the JSON block") + "id=\"report\">".len();
    let end = start + dom[start..].find("</script>").unwrap();
    let embedded: serde_json::Value = serde_json::from_str(&dom[start..end]).unwrap();
    assert_eq!(embedded["report"]["target"], "pairs");
    assert_eq!(embedded["report"]["triangles_in"], 2900);
    // Nothing was blocked by the policy, and the check can see a block when there is one.
    assert!(!log.contains("Content Security Policy"), "{log}");
    let control = dir.join("control.html");
    std::fs::write(
        &control,
        format!(
            "<!DOCTYPE html><html><head><meta http-equiv=\"Content-Security-Policy\" content=\"{}\"></head><body><img src=\"https://example.invalid/x.png\"></body></html>",
            rtmesh_policy()
        ),
    )
    .unwrap();
    let (_, control_log) = headless(&chromium, &control, &["--dump-dom"]);
    assert!(
        control_log.contains("Content Security Policy"),
        "{control_log}"
    );
    // A screenshot for a person to look at (kept in target/).
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    headless(
        &chromium,
        &report,
        &[
            "--window-size=1200,2400",
            &format!("--screenshot={}", shot.display()),
        ],
    );
    let png = std::fs::read(&shot).expect("a screenshot");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 20_000,
        "{} bytes",
        png.len()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The policy the report declares, read from a report's own head.
fn rtmesh_policy() -> &'static str {
    "default-src 'none'; img-src data:; style-src 'unsafe-inline'"
}

/// A folder that holds one mesh is still a folder: OUT mirrors it (`OUT/sub/one.obj`),
/// as it would with many, rather than naming the one output file.
#[test]
fn a_folder_of_one_file_is_mirrored_into_the_output_folder() {
    let dir = temp_dir("one-file-folder");
    let input = dir.join("in");
    std::fs::create_dir_all(input.join("sub")).unwrap();
    std::fs::write(input.join("sub/one.obj"), QUADS).unwrap();
    let output = dir.join("out");
    let out = optimize(&input, &output, &["--size", "16x16", "--runs", "1"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let written = std::fs::read_to_string(output.join("sub/one.obj")).unwrap();
    assert_eq!(written.lines().filter(|l| l.starts_with("f ")).count(), 4);
    std::fs::remove_dir_all(&dir).ok();
}

/// A batch's OUT or report named like a file is refused before any work, rather than
/// made a folder of that name.
#[test]
fn a_batch_refuses_an_output_named_like_a_file() {
    let dir = temp_dir("batch-file-name");
    let input = dir.join("in");
    std::fs::create_dir_all(&input).unwrap();
    std::fs::write(input.join("one.obj"), QUADS).unwrap();
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let (glb, out, html) = (path("all.glb"), path("out"), path("r.html"));
    for (extra, option) in [
        (vec!["-o", &glb], "-o"),
        (vec!["-o", &out, "--report", &html], "--report"),
    ] {
        let mut args = vec!["optimize", input.to_str().unwrap()];
        args.extend(extra);
        let out = rtmesh(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(&format!("error: {option} ")), "{stderr}");
        assert!(stderr.contains("this names a file"), "{stderr}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["in"], "nothing is made before the error");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_output_never_replaces_its_input() {
    let dir = temp_dir("in-place");
    let input = dir.join("quads.obj");
    std::fs::write(&input, QUADS).unwrap();
    let out = optimize(&input, &input, &["--size", "16x16", "--runs", "1"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("quads.obj: this is the input file"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&input).unwrap(), QUADS);
    // The same for the other writers, and for a .gltf's buffer file.
    let gltf = dir.join("quads.gltf");
    assert!(
        rtmesh(&["convert", input.to_str().unwrap(), gltf.to_str().unwrap()])
            .status
            .success()
    );
    let buffer = std::fs::read(dir.join("quads.bin")).unwrap();
    let renamed = dir.join("renamed.gltf");
    let json = std::fs::read_to_string(&gltf).unwrap();
    std::fs::write(&renamed, json.replace("quads.bin", "other.bin")).unwrap();
    std::fs::write(dir.join("other.bin"), &buffer).unwrap();
    let input_str = input.to_str().unwrap();
    for args in [
        vec!["convert", input_str, input_str],
        vec!["pair", input_str, "-o", input_str],
        vec!["repair", input_str, "-o", input_str],
        vec!["strip", input_str, "-o", input_str],
    ] {
        let out = rtmesh(&args);
        assert!(!out.status.success(), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("this is the input file"));
    }
    let other = dir.join("other.gltf");
    let out = rtmesh(&[
        "convert",
        renamed.to_str().unwrap(),
        other.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("other.bin: this is the buffer"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&input).unwrap(), QUADS);
    assert_eq!(std::fs::read(dir.join("other.bin")).unwrap(), buffer);
    // A batch: one error before any work, for its own input or another's.
    let batch = dir.join("batch");
    std::fs::create_dir_all(&batch).unwrap();
    std::fs::write(batch.join("a.obj"), QUADS).unwrap();
    std::fs::copy(dir.join("quads.gltf"), batch.join("a.gltf")).unwrap();
    std::fs::copy(dir.join("quads.bin"), batch.join("quads.bin")).unwrap();
    let out = optimize(
        &batch,
        &batch,
        &["--size", "16x16", "--runs", "1", "--json"],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty(), "no file was started");
    assert!(
        stderr.contains("a.gltf: this is the input file"),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert_eq!(std::fs::read_to_string(batch.join("a.obj")).unwrap(), QUADS);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_output_folder_inside_the_input_folder_is_not_read_as_input() {
    let dir = temp_dir("nested-output");
    std::fs::write(dir.join("quads.obj"), QUADS).unwrap();
    let output = dir.join("out");
    let reports = dir.join("reports");
    for _ in 0..2 {
        let out = optimize(
            &dir,
            &output,
            &[
                "--size",
                "16x16",
                "--runs",
                "1",
                "--report",
                reports.to_str().unwrap(),
                "--json",
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // One file each time: the first run's output and report are not inputs.
        assert_eq!(lines(&out).len(), 1);
    }
    assert!(output.join("quads.obj").is_file());
    assert!(!output.join("out").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A mirrored OBJ keeps its material library and textures: they are copied beside it
/// (before, `OUT/sub/a.obj` named an `a.mtl` that was not there).
#[test]
fn the_files_an_output_refers_to_are_copied_beside_it() {
    let dir = temp_dir("side-files");
    let input = dir.join("in");
    std::fs::create_dir_all(input.join("sub/tex")).unwrap();
    let obj = format!("mtllib a.mtl\nusemtl leaf\n{QUADS}");
    std::fs::write(input.join("sub/a.obj"), obj).unwrap();
    std::fs::write(input.join("sub/a.mtl"), "newmtl leaf\nmap_d tex/leaf.png\n").unwrap();
    std::fs::write(input.join("sub/tex/leaf.png"), [7u8; 3]).unwrap();
    let output = dir.join("out");
    let out = optimize(
        &input,
        &output,
        &["--size", "16x16", "--runs", "1", "--json"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = &lines(&out)[0];
    let copied: Vec<PathBuf> = serde_json::from_value(line["side_files"].clone()).unwrap();
    assert_eq!(
        copied,
        [output.join("sub/a.mtl"), output.join("sub/tex/leaf.png")]
    );
    assert_eq!(
        std::fs::read(output.join("sub/tex/leaf.png")).unwrap(),
        [7; 3]
    );
    let written = std::fs::read_to_string(output.join("sub/a.obj")).unwrap();
    assert!(written.contains("mtllib a.mtl\n") && written.contains("usemtl leaf\n"));
    // Files that share a library and a texture, two jobs at once: each copy is whole.
    let texture: Vec<u8> = (0..4u32 << 20).map(|i| (i % 251) as u8).collect();
    std::fs::write(input.join("sub/tex/leaf.png"), &texture).unwrap();
    for name in ["b", "c", "d", "e"] {
        let obj = format!("mtllib a.mtl\nusemtl leaf\n{QUADS}");
        std::fs::write(input.join(format!("sub/{name}.obj")), obj).unwrap();
    }
    std::fs::remove_dir_all(&output).unwrap();
    let out = optimize(&input, &output, &["--size", "0x0", "--jobs", "2", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(lines(&out).len(), 5);
    assert_eq!(
        std::fs::read(output.join("sub/tex/leaf.png")).unwrap(),
        texture
    );
    let left: Vec<_> = std::fs::read_dir(output.join("sub/tex")).unwrap().collect();
    assert_eq!(left.len(), 1, "no temporary copy left behind");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_report_says_what_the_output_goes_without() {
    let dir = temp_dir("left-out");
    let input = dir.join("faces.ply");
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 2\nproperty list uchar int vertex_indices\nproperty int label\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 4\n3 0 2 3 5\n0 2\n";
    std::fs::write(&input, ply).unwrap();
    let report = dir.join("faces.html");
    let report_arg = report.to_str().unwrap();
    let extra = ["--report", report_arg, "--size", "32x32", "--runs", "1"];
    let out = optimize(&input, &dir.join("faces.glb"), &extra);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(&report).unwrap();
    for text in [
        "The output goes without what rtmesh does not read:</p>\n<ul>\n<li>PLY element 'edge': 1</li>",
        "The output goes without what the output's format cannot hold:</p>\n<ul>\n<li>triangle attributes label",
    ] {
        assert!(html.contains(text), "the page lacks {text:?}");
    }
}
