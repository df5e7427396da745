//! `orogen tiles` as a user runs it: an output that is neither a folder nor
//! an archive is refused before any work (it became a folder named
//! `bad.png`), a folder whose name has a dot is written when the path ends
//! with `/`, and `-q` prints nothing.

use super::common::cli::{data, fails, orogen, s};

#[test]
fn outputs_are_folders_or_archives_and_quiet_is_quiet() {
    let dem = data("srtm/N43E007.hgt");
    let d = tempfile::tempdir().unwrap();
    for bad in ["bad.png", "x.tif"] {
        let out = d.path().join(bad);
        let e = fails(orogen().args(["tiles", s(&dem), "-o", s(&out), "--max-zoom", "8"]));
        assert!(
            e.contains(bad) && e.contains(".mbtiles") && e.contains("end the path with /"),
            "{e}"
        );
        assert!(!out.exists(), "{bad} was created");
    }
    // an existing file as the folder output
    let file = d.path().join("plain");
    std::fs::write(&file, b"x").unwrap();
    let e = fails(orogen().args(["tiles", s(&dem), "-o", s(&file), "--max-zoom", "8"]));
    assert!(e.contains("is a file"), "{e}");
    // a folder with a dot in its name, and -q: nothing on stderr
    let dotted = format!("{}/", d.path().join("tiles.v2").display());
    let o = orogen()
        .args(["tiles", s(&dem), "-o", &dotted, "--max-zoom", "8", "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stderr.is_empty(),
        "-q printed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(d.path().join("tiles.v2/metadata.json").is_file());
}
