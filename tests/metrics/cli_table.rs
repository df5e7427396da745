//! `orogen metric table` and the new metrics through the built binary:
//! files written, markdown/CSV shapes, the heat map is a PNG of the right
//! size, errors name what is accepted; the eight new metrics against closed
//! forms and brute-force definitions on small synthetic surfaces.

use crate::common::cli::{ok, orogen};
use std::path::Path;
use std::process::Output;

const DEM: &str = "tests/data/whitebox_DEM.tif";

/// `orogen metric table DEM -o DIR EXTRA`.
fn table(dir: &Path, extra: &[&str]) -> Output {
    orogen()
        .args(["metric", "table", DEM, "-o"])
        .arg(dir)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn metric_table_writes_cost_and_correlation() {
    let dir = tempfile::tempdir().unwrap();
    let out = table(
        dir.path(),
        &[
            "--radii",
            "200m,3c",
            "--only",
            "slope,tpi,ors",
            "--corr-radius",
            "2c",
            "-q",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cost = std::fs::read_to_string(dir.path().join("cost.csv")).unwrap();
    // header + slope + tpi x2 + ors x2
    assert_eq!(cost.lines().count(), 6, "{cost}");
    assert!(cost.lines().nth(1).unwrap().starts_with("slope,,0,"));
    let md = std::fs::read_to_string(dir.path().join("cost.md")).unwrap();
    assert!(md.contains("| ors |") && md.contains("r = 200 m"), "{md}");
    let legend = std::fs::read_to_string(dir.path().join("correlation_legend.csv")).unwrap();
    let n = legend.lines().count() - 1;
    assert!(n > 30, "{legend}");
    let corr = std::fs::read_to_string(dir.path().join("correlation.csv")).unwrap();
    assert_eq!(corr.lines().count(), n + 1);
    assert!(corr.lines().all(|l| l.split(',').count() == n + 1));
    // The heat map: n x n cells of 20 pixels after a label margin, each in
    // the diverging ramp of its coefficient in correlation.csv (white at 0,
    // red (255, 255(1 − c), 255(1 − c)) up to +1, blue (255(1 + c),
    // 255(1 + c), 255) down to −1; the CSV's 4 decimals allow ±1).
    let d = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(dir.path().join("correlation.png")).unwrap(),
    ));
    let mut r = d.read_info().unwrap();
    let mut px = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut px).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let (w, h) = (info.width as usize, info.height as usize);
    assert_eq!(w, h, "a square heat map");
    let margin = w - n * 20;
    assert!((4..=40).contains(&margin), "margin {margin}");
    for (i, line) in corr.lines().skip(1).enumerate() {
        for (j, v) in line.split(',').skip(1).enumerate() {
            let c: f64 = v.parse().unwrap_or(f64::NAN);
            let want = if !c.is_finite() {
                [160.0, 160.0, 160.0]
            } else if c >= 0.0 {
                [255.0, 255.0 * (1.0 - c), 255.0 * (1.0 - c)]
            } else {
                [255.0 * (1.0 + c), 255.0 * (1.0 + c), 255.0]
            };
            let (x, y) = (margin + j * 20 + 10, margin + i * 20 + 10);
            let got = &px[(y * w + x) * 3..(y * w + x) * 3 + 3];
            for k in 0..3 {
                assert!(
                    (got[k] as f64 - want[k]).abs() <= 1.0,
                    "cell ({i}, {j}) r = {c}: {got:?}, expected {want:?}"
                );
            }
        }
    }
}

#[test]
fn metric_table_errors_name_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let out = table(dir.path(), &["--only", "slope,bogus"]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("unknown metric 'bogus'") && e.contains("jut"),
        "{e}"
    );
    let out = table(dir.path(), &["--max-cells", "100"]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("whitebox_DEM.tif") && e.contains("--max-cells"),
        "{e}"
    );
    let out = table(dir.path(), &["--radii", "-5m"]);
    assert!(!out.status.success());
}

/// Side of the synthetic DEMs (cells of 10 m, centre cell at (C, C)).
const N: usize = 41;
const C: f64 = 20.0;
const CELL: f64 = 10.0;
/// The eight metrics of `new_metrics_through_the_cli`, their file names.
const EIGHT: &str = "directional_slope:azimuth=30,average_slope:radius=30m,fractional_laplacian:radius=3c:s=0.25,hillslope_asymmetry:radius=5c,shary_landform,ors:radius=3c,jut:radius=3c,rut:radius=3c";
const FILES: [&str; 8] = [
    "directional_slope_a30",
    "average_slope_r30m",
    "fractional_laplacian_r3c_s0.25",
    "hillslope_asymmetry_r5c",
    "shary_landform",
    "ors_r3c",
    "jut_r3c",
    "rut_r3c",
];

/// z(E, N) in metres east and north of the centre cell, as a GeoTIFF.
fn surface(dir: &Path, name: &str, z: impl Fn(f64, f64) -> f64) -> (std::path::PathBuf, Vec<f64>) {
    use orogen::io::geotiff::{write_geotiff, WriteOptions};
    use orogen::raster::{AnyGrid, Crs, GeoRef, Grid};
    let v: Vec<f64> = (0..N * N)
        .map(|k| z(((k % N) as f64 - C) * CELL, (C - (k / N) as f64) * CELL))
        .collect();
    let g = Grid::from_vec(N, N, v.iter().map(|&x| x as f32).collect()).unwrap();
    let p = dir.join(format!("{name}.tif"));
    let geo = GeoRef::north_up(500_000.0, 4_000_000.0, CELL, Crs::projected(32611));
    write_geotiff(&p, &AnyGrid::F32(g), &geo, &WriteOptions::default()).unwrap();
    (p, v.iter().map(|&x| x as f32 as f64).collect())
}

/// The eight metrics of `dem`, read back by name.
fn eight(dem: &Path, out: &Path) -> std::collections::HashMap<&'static str, Vec<f64>> {
    ok(orogen()
        .args(["metric", "-q", "--tile", "16", "-m", EIGHT, "-o"])
        .arg(out)
        .arg(dem));
    FILES
        .iter()
        .map(|&f| {
            let src = orogen::io::open_raster(
                &out.join(format!("{f}.tif")),
                &orogen::io::OpenOptions::default(),
            )
            .unwrap();
            let g = orogen::raster::read_window::<f64>(
                src.as_ref(),
                orogen::raster::Window::full(N, N),
            )
            .unwrap();
            (f, g.data().to_vec())
        })
        .collect()
}

/// Cells at least `m` cells from the edge.
fn inner(m: usize) -> impl Iterator<Item = (usize, usize)> {
    (m..N - m).flat_map(move |y| (m..N - m).map(move |x| (x, y)))
}

/// Horn's 3x3 gradient (dz/dE, dz/dN) of cell (x, y), written from Horn 1981.
fn horn(z: &[f64], x: usize, y: usize) -> (f64, f64) {
    let a = |dx: i64, dy: i64| z[(y as i64 + dy) as usize * N + (x as i64 + dx) as usize];
    let p = ((a(1, -1) + 2.0 * a(1, 0) + a(1, 1)) - (a(-1, -1) + 2.0 * a(-1, 0) + a(-1, 1)))
        / (8.0 * CELL);
    // Rows run south: dy = -1 is the northern row.
    let q = ((a(-1, -1) + 2.0 * a(0, -1) + a(1, -1)) - (a(-1, 1) + 2.0 * a(0, 1) + a(1, 1)))
        / (8.0 * CELL);
    (p, q)
}

/// ORS, jut and rut of cell (x, y) over the disk of radius 3 cells, by their
/// definitions (Earl & Metzler 2015; Xu 2022), all cells of the disk inside.
fn relief_by_hand(z: &[f64], x: usize, y: usize) -> (f64, f64, f64) {
    let f = |u: f64| {
        let a = u.atan();
        4.0 / std::f64::consts::PI.powi(3) * (2.0 * u * a - (1.0 + u * u).ln() - a * a)
    };
    let (mut ors, mut jut, mut rut) = (0.0, 0.0f64, 0.0f64);
    for dy in -3i64..=3 {
        for dx in -3i64..=3 {
            if (dx, dy) == (0, 0) || dx * dx + dy * dy > 9 {
                continue;
            }
            let d = CELL * ((dx * dx + dy * dy) as f64).sqrt();
            let zq = z[(y as i64 + dy) as usize * N + (x as i64 + dx) as usize];
            let del = z[y * N + x] - zq;
            if del > 0.0 {
                ors += f(del / d) * CELL * CELL;
            }
            let h = del.abs() / (d * d + del * del).sqrt();
            jut = jut.max(del * h);
            rut = rut.max(-del * h);
        }
    }
    (ors.sqrt(), jut, rut)
}

fn close(got: f64, want: f64, tol: f64, what: &str, x: usize, y: usize) {
    assert!(
        (got - want).abs() <= tol * (1.0 + want.abs()),
        "{what} ({x}, {y}): {got}, expected {want}"
    );
}

/// Every metric against a closed form or a brute force of its definition
/// on a plane, a dome, a bowl and an asymmetric valley.
#[test]
fn new_metrics_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Plane z = 100 + 0.3 E + 0.2 N.
    let (dem, z) = surface(d, "plane", |e, n| 100.0 + 0.3 * e + 0.2 * n);
    let m = eight(&dem, &d.join("plane"));
    // Azimuth 30°: u = (sin 30°, cos 30°) (east, north).
    let c30 = 0.75f64.sqrt();
    let slope_deg = 0.13f64.sqrt().atan().to_degrees();
    for (x, y) in inner(1) {
        let k = y * N + x;
        close(
            m["directional_slope_a30"][k],
            0.3 * 0.5 + 0.2 * c30,
            1e-5,
            "directional slope",
            x,
            y,
        );
        close(
            m["average_slope_r30m"][k],
            slope_deg,
            1e-5,
            "average slope",
            x,
            y,
        );
        // Descent towards azimuth 236°: within 45° of south only, so the
        // north-facing side is empty everywhere.
        assert!(
            m["hillslope_asymmetry_r5c"][k].is_nan(),
            "asymmetry on a plane ({x}, {y})"
        );
    }
    for (x, y) in inner(3) {
        let k = y * N + x;
        // The disk is symmetric: the plane's linear part cancels.
        close(
            m["fractional_laplacian_r3c_s0.25"][k],
            0.0,
            1e-6,
            "fractional laplacian",
            x,
            y,
        );
        let (ors, jut, rut) = relief_by_hand(&z, x, y);
        close(m["ors_r3c"][k], ors, 1e-4, "ors", x, y);
        close(m["jut_r3c"][k], jut, 1e-4, "jut", x, y);
        close(m["rut_r3c"][k], rut, 1e-4, "rut", x, y);
    }

    // Dome z = 500 − b r² and bowl z = 500 + b r², b = 0.002 /m: for
    // z = a r² the fractional Laplacian is −a C(s) ΔA Σ |y|^(−2s) everywhere.
    let b = 0.002;
    // C(s) ΔA Σ_{0<|y|≤30 m} |y|^(−2s) for s = 1/4, with
    // C(s) = s 4^s Γ(1+s) / (π Γ(1−s)) (Di Nezza et al. 2012).
    let (g125, g075) = (0.906_402_477_055_477, 1.225_416_702_465_178);
    let cs = 0.25 * 4f64.powf(0.25) * g125 / (std::f64::consts::PI * g075);
    let mut lattice = 0.0;
    for dy in -3i64..=3 {
        for dx in -3i64..=3 {
            let r2 = (dx * dx + dy * dy) as f64;
            if r2 > 0.0 && r2 <= 9.0 {
                lattice += (CELL * r2.sqrt()).powf(-0.5);
            }
        }
    }
    let frac = cs * CELL * CELL * lattice * b;
    // Shary: the dome is divergent and accelerating, elliptic with
    // kv < kh (class 11); the bowl convergent, decelerating, kv > kh (2).
    for (sign, name, class) in [(-1.0, "dome", 11.0), (1.0, "bowl", 2.0)] {
        let (dem, z) = surface(d, name, |e, n| 500.0 + sign * b * (e * e + n * n));
        let m = eight(&dem, &d.join(name));
        let slope_at = |x: usize, y: usize| {
            let (e, n) = ((x as f64 - C) * CELL, (C - y as f64) * CELL);
            (2.0 * b * (e * e + n * n).sqrt()).atan().to_degrees()
        };
        for (x, y) in inner(1) {
            let k = y * N + x;
            let (e, n) = ((x as f64 - C) * CELL, (C - y as f64) * CELL);
            // Horn's differences are exact on a quadratic without cross term.
            let want = sign * 2.0 * b * (e * 0.5 + n * c30);
            close(m["directional_slope_a30"][k], want, 1e-5, name, x, y);
            // Mean slope angle over the 7 x 7 window, cells with a gradient
            // (not on the raster's edge).
            let (mut sum, mut cnt) = (0.0, 0.0);
            for yy in y.saturating_sub(3).max(1)..=(y + 3).min(N - 2) {
                for xx in x.saturating_sub(3).max(1)..=(x + 3).min(N - 2) {
                    sum += slope_at(xx, yy);
                    cnt += 1.0;
                }
            }
            close(
                m["average_slope_r30m"][k],
                sum / cnt,
                1e-5,
                "average slope",
                x,
                y,
            );
            if (x as f64 - C).abs() + (y as f64 - C).abs() >= 2.0 {
                assert_eq!(
                    m["shary_landform"][k], class,
                    "{name} Shary class ({x}, {y})"
                );
            }
        }
        for (x, y) in inner(3) {
            let k = y * N + x;
            close(
                m["fractional_laplacian_r3c_s0.25"][k],
                -sign * frac,
                1e-4,
                name,
                x,
                y,
            );
            let (ors, jut, rut) = relief_by_hand(&z, x, y);
            close(m["ors_r3c"][k], ors, 1e-4, "ors", x, y);
            close(m["jut_r3c"][k], jut, 1e-4, "jut", x, y);
            close(m["rut_r3c"][k], rut, 1e-4, "rut", x, y);
        }
    }

    // An east-west valley: 0.2 up to the north, 0.4 up to the south. The
    // north-facing (azimuth 0) side is the steeper one; the asymmetry is
    // the log10 ratio of the mean gradients (over 5 %) of the cells facing
    // north and south within ±45°, in the 11 x 11 window, from Horn's
    // gradients computed here.
    let (dem, z) = surface(d, "valley", |_, n| {
        100.0 + if n > 0.0 { 0.2 * n } else { -0.4 * n }
    });
    let m = eight(&dem, &d.join("valley"));
    let mut grad = vec![(f64::NAN, f64::NAN); N * N];
    for (x, y) in inner(1) {
        grad[y * N + x] = horn(&z, x, y);
    }
    let mut near_bottom = 0;
    for (x, y) in inner(6) {
        let (mut sn, mut nn, mut ss, mut ns) = (0.0, 0.0, 0.0, 0.0);
        for yy in y - 5..=y + 5 {
            for xx in x - 5..=x + 5 {
                let (p, q) = grad[yy * N + xx];
                let g = p.hypot(q);
                if g <= 0.05 {
                    continue;
                }
                let aspect = (-p).atan2(-q).to_degrees().rem_euclid(360.0);
                if !(45.0..=315.0).contains(&aspect) {
                    sn += g;
                    nn += 1.0;
                } else if (135.0..225.0).contains(&aspect) {
                    ss += g;
                    ns += 1.0;
                }
            }
        }
        let got = m["hillslope_asymmetry_r5c"][y * N + x];
        if nn == 0.0 || ns == 0.0 {
            assert!(
                got.is_nan(),
                "valley asymmetry ({x}, {y}) = {got}, one side empty"
            );
        } else {
            near_bottom += 1;
            close(
                got,
                ((sn / nn) / (ss / ns)).log10(),
                1e-5,
                "valley asymmetry",
                x,
                y,
            );
        }
    }
    assert!(near_bottom > 100, "{near_bottom} cells see both sides");

    // The eight metrics on the real DEM, in tiles.
    ok(orogen()
        .args(["metric", DEM, "-q", "--tile", "50", "-m"])
        .arg("directional_slope:azimuth=45,average_slope:radius=300m,fractional_laplacian:radius=3c:s=0.25,hillslope_asymmetry:radius=5c,shary_landform,ors:radius=3c,jut:radius=3c,rut:radius=3c")
        .arg("-o")
        .arg(dir.path()));
    for f in [
        "directional_slope_a45.tif",
        "average_slope_r300m.tif",
        "fractional_laplacian_r3c_s0.25.tif",
        "hillslope_asymmetry_r5c.tif",
        "shary_landform.tif",
        "ors_r3c.tif",
        "jut_r3c.tif",
        "rut_r3c.tif",
    ] {
        assert!(dir.path().join(f).exists(), "{f} missing");
    }
    let out = orogen()
        .args(["metric", DEM, "-m", "fractional_laplacian:s=2", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("0 < s < 1"));
}
