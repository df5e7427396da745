//! Outputs of a comparison: `compare.json` (every number), the PNG charts
//! as files, hillshade thumbnails of both terrains, and `compare.html`
//! (self-contained: the same PNGs inlined, a table of distances). Charts
//! and page helpers are the report's ([`crate::report`]).

use super::{Comparison, PairHistogram, Terrain, LANDFORMS};
use crate::error::{Error, Result};
use crate::raster::MemRaster;
use crate::report::{
    chart_key, esc, fmt_num, html_page, png_img, write_html, Chart, Series, Style, COLOUR_A,
    COLOUR_B,
};
use crate::tiles::render::{render_preview, RenderKind, RenderOptions};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A chart written as `DIR/<name>.png` and shown in the page.
struct Figure {
    file: String,
    title: String,
    caption: String,
    series: Vec<Series>,
    png: Vec<u8>,
}

fn two(cmp: &Comparison, style: Style, xs_a: Vec<f64>, ya: Vec<f64>, yb: Vec<f64>) -> Vec<Series> {
    vec![
        Series {
            label: cmp.a.name.clone(),
            colour: COLOUR_A,
            style,
            xs: xs_a.clone(),
            ys: ya,
        },
        Series {
            label: cmp.b.name.clone(),
            colour: COLOUR_B,
            style,
            xs: xs_a,
            ys: yb,
        },
    ]
}

fn ymax(series: &[Series]) -> f64 {
    series
        .iter()
        .flat_map(|s| s.ys.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-12)
}

/// Bar chart of a pair histogram over `x` (bin edges, finite).
fn bars(cmp: &Comparison, h: &PairHistogram, x: Vec<f64>) -> Result<(Vec<Series>, Vec<u8>)> {
    let series = two(cmp, Style::Bars, x.clone(), h.a.clone(), h.b.clone());
    let png = Chart {
        width: 360,
        height: 160,
        x_range: (x[0], x[x.len() - 1]),
        y_range: (0.0, ymax(&series)),
        series: series.clone(),
    }
    .to_png()?;
    Ok((series, png))
}

fn figures(cmp: &Comparison) -> Result<Vec<Figure>> {
    let mut out = vec![];
    // Hypsometric curves.
    let n = cmp.a.hypsometry.len();
    let xs: Vec<f64> = (0..n).map(|k| k as f64 / (n - 1) as f64).collect();
    let series = two(
        cmp,
        Style::Line,
        xs,
        cmp.a.hypsometry.clone(),
        cmp.b.hypsometry.clone(),
    );
    out.push(Figure {
        file: "hypsometry".into(),
        title: "hypsometric curves".into(),
        caption: format!(
            "x: relative height (z − zmin)/(zmax − zmin); y: fraction of the area at or above it. Integrals {:.3} and {:.3}; mean |difference| {:.4}",
            cmp.a.hypsometric_integral,
            cmp.b.hypsometric_integral,
            cmp.distances["hypsometric_curve_l1"]
        ),
        png: Chart {
            width: 360,
            height: 220,
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
            series: series.clone(),
        }
        .to_png()?,
        series,
    });
    let (series, png) = bars(cmp, &cmp.slope, cmp.slope.edges.clone())?;
    out.push(Figure {
        file: "slope".into(),
        title: "slope distribution".into(),
        caption: format!(
            "Horn slope, 1° bins over 0–90°; fractions of cells. EMD {} °",
            fmt_num(cmp.slope.distance)
        ),
        series,
        png,
    });
    let (series, png) = bars(cmp, &cmp.curvature, cmp.curvature.edges.clone())?;
    out.push(Figure {
        file: "curvature".into(),
        title: "profile curvature distribution".into(),
        caption: format!(
            "Evans profile curvature (1/m, convex positive), {} bins over ±{:.3e}; end bins hold the tails. EMD {:.3e} 1/m",
            cmp.curvature.a.len(),
            cmp.curvature.edges[cmp.curvature.edges.len() - 1],
            cmp.curvature.distance
        ),
        series,
        png,
    });
    let (series, png) = bars(cmp, &cmp.geomorphons, cmp.geomorphons.edges.clone())?;
    out.push(Figure {
        file: "geomorphons".into(),
        title: "geomorphon landforms".into(),
        caption: format!(
            "classes 1–10: {}; total variation {}",
            LANDFORMS.join(", "),
            fmt_num(cmp.geomorphons.distance)
        ),
        series,
        png,
    });
    // Horton: mean stream counts per order (log10).
    let (ha, hb) = (&cmp.a.drainage.horton, &cmp.b.drainage.horton);
    let maxo = ha.max_order.max(hb.max_order).max(1) as usize;
    let lg = |c: &[u64]| -> Vec<f64> {
        (0..maxo)
            .map(|i| c.get(i).map_or(f64::NAN, |&v| (v as f64).log10()))
            .collect()
    };
    let xs: Vec<f64> = (1..=maxo).map(|o| o as f64).collect();
    let series = two(cmp, Style::Line, xs, lg(&ha.count), lg(&hb.count));
    out.push(Figure {
        file: "horton".into(),
        title: "Horton: streams per Strahler order".into(),
        caption: format!(
            "x: order 1–{maxo}; y: log10(number of streams). Bifurcation ratios {} and {}",
            fmt_num(ha.bifurcation_ratio),
            fmt_num(hb.bifurcation_ratio)
        ),
        png: Chart {
            width: 360,
            height: 160,
            x_range: (1.0, maxo.max(2) as f64),
            y_range: (0.0, ymax(&series)),
            series: series.clone(),
        }
        .to_png()?,
        series,
    });
    for (name, h) in &cmp.orometry {
        // Bins by index: the edges are uneven and the last one is open.
        let x: Vec<f64> = (0..h.edges.len()).map(|i| i as f64).collect();
        let (series, png) = bars(cmp, h, x)?;
        let bins: Vec<String> = h
            .edges
            .windows(2)
            .map(|w| {
                if w[1] >= f64::MAX {
                    format!("≥{}", w[0])
                } else {
                    format!("{}–{}", w[0], w[1])
                }
            })
            .collect();
        out.push(Figure {
            file: format!("oro_{name}"),
            title: format!("orometry: {name}"),
            caption: format!(
                "pooled histogram over the disks (x: bin index; bins {}). EMD {}",
                bins.join(", "),
                fmt_num(h.distance)
            ),
            series,
            png,
        });
    }
    Ok(out)
}

/// Hillshaded elevation thumbnail of a terrain as PNG bytes.
fn thumbnail(t: &Terrain, dir: &Path, file: &str) -> Result<Vec<u8>> {
    let path = dir.join(file);
    let src = MemRaster::from_grid(t.dem.clone(), t.georef.clone());
    let opts = RenderOptions {
        kind: RenderKind::Elevation,
        max_size: 360,
        legend: true,
        sea: false,
        ..Default::default()
    };
    render_preview(&src, &path, &opts)?;
    std::fs::read(&path).map_err(|e| Error::io(&path, e))
}

/// Write `compare.json`, `compare.html`, the chart PNGs and the thumbnails
/// `a.png`/`b.png` into `dir` (created). Returns the files written.
pub fn write_outputs(
    cmp: &Comparison,
    a: &Terrain,
    b: &Terrain,
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut written = vec![];
    let json = serde_json::to_string_pretty(cmp)
        .map_err(|e| Error::invalid(format!("comparison does not serialise: {e}")))?;
    let jp = dir.join("compare.json");
    crate::io::png::write_atomic(&jp, json.as_bytes())?;
    written.push(jp);
    let figs = figures(cmp)?;
    for f in &figs {
        let p = dir.join(format!("{}.png", f.file));
        crate::io::png::write_atomic(&p, &f.png)?;
        written.push(p);
    }
    let ta = thumbnail(a, dir, "a.png")?;
    let tb = thumbnail(b, dir, "b.png")?;
    written.push(dir.join("a.png"));
    written.push(dir.join("b.png"));

    let mut body = format!(
        "<h1>orogen compare: {} vs {}</h1>",
        esc(&cmp.a.name),
        esc(&cmp.b.name)
    );
    for (t, an, png, col) in [(a, &cmp.a, &ta, COLOUR_A), (b, &cmp.b, &tb, COLOUR_B)] {
        let [r, g, bl] = col;
        let _ = write!(
            body,
            "<div class='out'><h3 style='color:rgb({r},{g},{bl})'>{}</h3>{}<p>{} x {} cells, {} km², cells ≈ {} m, z {}–{} m</p></div>",
            esc(&t.name),
            png_img(png, &t.name),
            an.width,
            an.height,
            fmt_num(an.area_km2),
            fmt_num(an.mean_cell_m),
            fmt_num(an.z_min),
            fmt_num(an.z_max)
        );
    }
    body.push_str("<h2>Distances</h2><p>0 = identical. EMD in the feature's unit; <i>_rel</i>: |a − b| / max(|a|, |b|); total variation for classes.</p><table><tr><th>distance</th><th>value</th></tr>");
    for (k, v) in &cmp.distances {
        let _ = write!(
            body,
            "<tr><td>{}</td><td>{}</td></tr>",
            esc(k),
            if v.is_finite() {
                format!("{v:.4}")
            } else {
                "undefined".into()
            }
        );
    }
    body.push_str("</table><h2>Figures</h2><table><tr><th>figure</th>");
    for an in [&cmp.a, &cmp.b] {
        let _ = write!(body, "<th>{}</th>", esc(&an.name));
    }
    body.push_str("</tr>");
    let row = |body: &mut String, name: &str, f: &dyn Fn(&super::Analysis) -> f64| {
        let _ = write!(
            body,
            "<tr><td>{name}</td><td>{}</td><td>{}</td></tr>",
            fmt_num(f(&cmp.a)),
            fmt_num(f(&cmp.b))
        );
    };
    row(&mut body, "pits per km²", &|x| x.pits.count_per_km2);
    row(&mut body, "pit volume per km² (m³)", &|x| {
        x.pits.volume_m3_per_km2
    });
    row(&mut body, "drainage density (km/km²)", &|x| {
        x.drainage.density_km_per_km2
    });
    row(&mut body, "Horton bifurcation ratio", &|x| {
        x.drainage.horton.bifurcation_ratio
    });
    row(&mut body, "Horton length ratio", &|x| {
        x.drainage.horton.length_ratio
    });
    row(&mut body, "Horton area ratio", &|x| {
        x.drainage.horton.area_ratio
    });
    row(&mut body, "hypsometric integral", &|x| {
        x.hypsometric_integral
    });
    row(&mut body, "peaks per km²", &|x| {
        x.oro.as_ref().map_or(f64::NAN, |p| p.peak_density_per_km2)
    });
    row(&mut body, "orometry disks", &|x| {
        x.oro.as_ref().map_or(0.0, |p| p.n_disks as f64)
    });
    let _ = write!(
        body,
        "</table><p>Channels: drainage area ≥ {} m². Peaks: prominence ≥ {} m; disks of radius {} m.</p>",
        fmt_num(cmp.a.drainage.channel_area_m2),
        fmt_num(cmp.min_prominence),
        fmt_num(cmp.radius_m)
    );
    for an in [&cmp.a, &cmp.b] {
        if let Some(n) = &an.oro_note {
            let _ = write!(body, "<p>orometry of {}: {}</p>", esc(&an.name), esc(n));
        }
    }
    body.push_str("<h2>Charts</h2>");
    for f in &figs {
        let _ = write!(
            body,
            "<div class='out'><h3>{}</h3>{}{}<p class='key' style='max-width:360px'>{}</p></div>",
            esc(&f.title),
            png_img(&f.png, &f.title),
            chart_key(&f.series),
            esc(&f.caption)
        );
    }
    let hp = dir.join("compare.html");
    write_html(
        &hp,
        &html_page(
            &format!("orogen compare: {} vs {}", cmp.a.name, cmp.b.name),
            &body,
        ),
    )?;
    written.push(hp);
    Ok(written)
}
