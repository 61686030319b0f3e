//! Inputs the fuzzers found that once panicked: each must now read as an error.

#[test]
fn fuzz_findings_are_errors_not_panics() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let error = rtmesh::io::read(&path).expect_err("a fuzz finding is malformed input");
        assert!(
            error
                .to_string()
                .contains(path.file_name().unwrap().to_str().unwrap()),
            "{error}"
        );
        checked += 1;
    }
    assert!(checked >= 1);
}
