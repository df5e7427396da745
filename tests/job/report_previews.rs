//! The job report's previews follow what each output holds: D8 codes and
//! landform classes get a class palette with bars per class and a legend
//! of directions, aspect a hue wheel with circular block means, flow
//! accumulation a log scale (on a linear one every river but the largest
//! is one dark colour).

use std::process::Command;

use crate::common::cli::data;

#[test]
fn previews_by_output_kind() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(data("bigtujunga_crop.tif"), dir.path().join("dem.tif")).unwrap();
    let job = dir.path().join("job.toml");
    std::fs::write(
        &job,
        r#"output_dir = "out"
[inputs]
dem = "dem.tif"
[[step]]
name = "filled"
run = "fill"
input = "dem"
output = "filled.tif"
[[step]]
name = "d8"
run = "flow"
input = "filled"
output = "d8.tif"
[[step]]
name = "acc"
run = "accumulate"
input = "d8"
output = "acc.tif"
[[step]]
name = "asp"
run = "aspect"
input = "dem"
output = "aspect.tif"
[[step]]
name = "m"
run = "metric"
input = "dem"
output = "m"
args = { metric = ["geomorphon:radius=5c", "slope"] }
"#,
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(["run", job.to_str().unwrap(), "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    let section = |file: &str| -> String {
        let i = html
            .find(&format!("{file}</h3>"))
            .unwrap_or_else(|| panic!("no section for {file}"));
        let j = html[i..]
            .find("</div>")
            .map(|j| i + j)
            .unwrap_or(html.len());
        html[i..j].to_string()
    };
    let d8 = section("d8.tif");
    assert!(d8.contains("classes (block centre cells)"), "{d8}");
    for name in ["NE", "SW", "NW", "128 NE: "] {
        assert!(d8.contains(name), "D8 legend lacks {name}: {d8}");
    }
    let acc = section("acc.tif");
    assert!(acc.contains("log scale"), "{acc}");
    let asp = section("aspect.tif");
    assert!(asp.contains("hue wheel"), "{asp}");
    let gm = section("geomorphon_r5c.tif");
    assert!(gm.contains("classes"), "{gm}");
    let slope = section("slope.tif");
    assert!(
        !slope.contains("classes") && !slope.contains("log scale"),
        "{slope}"
    );
    let filled = section("filled.tif");
    assert!(!filled.contains("log scale"), "elevations stay linear");
}
