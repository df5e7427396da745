//! `orogen view`: a localhost viewer for tile pyramids. Serves the tiles
//! (a z/x/y folder, an MBTiles file, or a PMTiles archive with HTTP range
//! requests for the pmtiles.js protocol) and a page showing them as 3D
//! terrain with hillshade in MapLibre GL JS. MapLibre and pmtiles.js come
//! from the npm registry, installed by `tools/viewer_setup.sh` into
//! `tools/node_modules`; nothing is fetched from the internet at view time.
//! The pyramid readers are `orogen::tiles::reader`; the small HTTP server
//! stays here (it serves files, it computes nothing).

use anyhow::{bail, Context, Result};
use clap::Args;
use orogen::tiles::TileSource;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `orogen view`.
#[derive(Args, Clone)]
#[command(
    after_help = "Examples:\n  orogen tiles dem.tif -o dem.pmtiles && orogen view dem.pmtiles\n  orogen view tiles/ --port 8080\nNeeds MapLibre GL JS from npm: bash tools/viewer_setup.sh (once)."
)]
pub struct ViewArgs {
    /// A pyramid from `orogen tiles`: folder, .mbtiles or .pmtiles.
    pub tiles: PathBuf,
    /// Port on 127.0.0.1 (0 = any free port).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Folder holding maplibre-gl/ and pmtiles/ (default: tools/node_modules
    /// of the orogen checkout, or $OROGEN_VIEWER_ASSETS).
    #[arg(long)]
    pub assets: Option<PathBuf>,
}

struct Site {
    source: TileSource,
    assets: PathBuf,
    page: String,
}

fn find_assets(given: Option<PathBuf>) -> Result<PathBuf> {
    let mut cands = vec![];
    if let Some(g) = given {
        cands.push(g);
    }
    if let Ok(e) = std::env::var("OROGEN_VIEWER_ASSETS") {
        cands.push(PathBuf::from(e));
    }
    if let Ok(exe) = std::env::current_exe() {
        // target/{release,debug}/orogen -> checkout/tools/node_modules
        if let Some(root) = exe
            .parent()
            .and_then(|p| p.parent())
            .and_then(|p| p.parent())
        {
            cands.push(root.join("tools/node_modules"));
        }
    }
    cands.push(PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tools/node_modules"
    )));
    for c in &cands {
        if c.join("maplibre-gl/dist/maplibre-gl.js").is_file() {
            return Ok(c.clone());
        }
    }
    bail!(
        "MapLibre GL JS not found (looked in {}); install it with `bash tools/viewer_setup.sh` (npm) or give --assets",
        cands.iter().map(|c| c.display().to_string()).collect::<Vec<_>>().join(", ")
    )
}

fn page(meta: &serde_json::Value, source_js: &str) -> String {
    let enc = meta.get("encoding");
    let dem = match enc.and_then(|e| e.as_str()) {
        Some("terrarium") => Some("terrarium"),
        Some("terrain-rgb") => Some("mapbox"),
        _ => None,
    };
    let b = meta
        .get("bounds")
        .and_then(|b| b.as_array())
        .map(|a| a.iter().filter_map(|v| v.as_f64()).collect::<Vec<_>>())
        .unwrap_or_else(|| vec![-180.0, -85.0, 180.0, 85.0]);
    let minz = meta.get("min_zoom").and_then(|v| v.as_u64()).unwrap_or(0);
    let maxz = meta.get("max_zoom").and_then(|v| v.as_u64()).unwrap_or(14);
    let layers = match dem {
        Some(_) => {
            r#"[{id:'bg',type:'background',paint:{'background-color':'#dfe6ea'}},
  {id:'shade',type:'hillshade',source:'shade',paint:{'hillshade-exaggeration':0.8}}]"#
        }
        None => {
            r#"[{id:'bg',type:'background',paint:{'background-color':'#dfe6ea'}},
  {id:'img',type:'raster',source:'dem'}]"#
        }
    };
    let src_type = if dem.is_some() {
        "raster-dem"
    } else {
        "raster"
    };
    let encoding = dem.map(|e| format!("encoding:'{e}',")).unwrap_or_default();
    let terrain = if dem.is_some() {
        "terrain:{source:'dem',exaggeration:1.5},"
    } else {
        ""
    };
    format!(
        r#"<!doctype html><html><head><meta charset="utf-8"><title>orogen view</title>
<link rel="stylesheet" href="/assets/maplibre-gl/dist/maplibre-gl.css">
<script src="/assets/maplibre-gl/dist/maplibre-gl.js"></script>
<script src="/assets/pmtiles/dist/pmtiles.js"></script>
<style>html,body,#map{{margin:0;height:100%}}</style></head><body><div id="map"></div><script>
if (window.pmtiles) {{ const p = new pmtiles.Protocol(); maplibregl.addProtocol('pmtiles', p.tile); }}
window.mapReady = false;
const map = new maplibregl.Map({{container:'map', canvasContextAttributes:{{preserveDrawingBuffer:true}},
 style:{{version:8, sources:{{dem:{{type:'{src_type}', {encoding} tileSize:256, minzoom:{minz}, maxzoom:{maxz}, {source_js} }},
   shade:{{type:'{src_type}', {encoding} tileSize:256, minzoom:{minz}, maxzoom:{maxz}, {source_js} }}}},
  {terrain} layers:{layers}}},
 bounds:[[{b0},{b1}],[{b2},{b3}]], minZoom:{minz}, pitch:55, bearing:-20}});
map.on('idle', () => {{ window.mapReady = true; }});
map.on('error', (e) => {{ window.mapError = String(e.error || e); }});
window.map = map;
</script></body></html>"#,
        b0 = b.first().copied().unwrap_or(-180.0),
        b1 = b.get(1).copied().unwrap_or(-85.0),
        b2 = b.get(2).copied().unwrap_or(180.0),
        b3 = b.get(3).copied().unwrap_or(85.0),
    )
}

pub fn run(a: ViewArgs) -> Result<()> {
    let assets = find_assets(a.assets.clone())?;
    let (source, meta) = TileSource::open(&a.tiles)?;
    let source_js = match source {
        TileSource::Pmtiles(_) => "url:'pmtiles://'+location.origin+'/data.pmtiles'".to_string(),
        _ => "tiles:[location.origin+'/tiles/{z}/{x}/{y}.png']".to_string(),
    };
    let site = Arc::new(Site {
        page: page(&meta, &source_js),
        source,
        assets,
    });
    let listener = TcpListener::bind(("127.0.0.1", a.port))
        .with_context(|| format!("port {} on 127.0.0.1 is taken; use --port", a.port))?;
    let addr = listener.local_addr()?;
    println!(
        "viewing {} at http://{addr}/ (Ctrl-C to stop)",
        a.tiles.display()
    );
    std::io::stdout().flush()?;
    for conn in listener.incoming() {
        let Ok(stream) = conn else { continue };
        let site = site.clone();
        std::thread::spawn(move || {
            let _ = serve(stream, &site);
        });
    }
    Ok(())
}

fn respond(
    s: &mut TcpStream,
    code: &str,
    ctype: &str,
    body: &[u8],
    extra: &str,
) -> std::io::Result<()> {
    write!(
        s,
        "HTTP/1.1 {code}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\nAccess-Control-Allow-Origin: *\r\nConnection: close\r\n{extra}\r\n",
        body.len()
    )?;
    s.write_all(body)
}

fn serve(mut stream: TcpStream, site: &Site) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let mut range = None;
    loop {
        let mut h = String::new();
        if reader.read_line(&mut h)? == 0 || h == "\r\n" || h == "\n" {
            break;
        }
        let lower = h.to_ascii_lowercase();
        if let Some(r) = lower.strip_prefix("range: bytes=") {
            let mut it = r.trim().splitn(2, '-');
            let a = it.next().and_then(|v| v.parse::<u64>().ok());
            let b = it.next().and_then(|v| v.trim().parse::<u64>().ok());
            range = a.map(|a| (a, b));
        }
    }
    let path = line.split_whitespace().nth(1).unwrap_or("/").to_string();
    let path = path.split('?').next().unwrap_or("/").to_string();
    if path == "/favicon.ico" {
        return respond(&mut stream, "204 No Content", "image/x-icon", b"", "");
    }
    if path == "/" {
        return respond(
            &mut stream,
            "200 OK",
            "text/html; charset=utf-8",
            site.page.as_bytes(),
            "",
        );
    }
    if let Some(rest) = path.strip_prefix("/assets/") {
        // Only the two packages' dist folders, no traversal.
        let ok = (rest.starts_with("maplibre-gl/dist/") || rest.starts_with("pmtiles/dist/"))
            && !rest.contains("..");
        if ok {
            if let Ok(b) = std::fs::read(site.assets.join(rest)) {
                let ct = if rest.ends_with(".css") {
                    "text/css"
                } else {
                    "application/javascript"
                };
                return respond(&mut stream, "200 OK", ct, &b, "");
            }
        }
        return respond(&mut stream, "404 Not Found", "text/plain", b"not found", "");
    }
    if path == "/data.pmtiles" {
        if let TileSource::Pmtiles(p) = &site.source {
            let mut f = std::fs::File::open(p)?;
            let size = f.metadata()?.len();
            let (a, b) = range.unwrap_or((0, None));
            let b = b
                .unwrap_or(size.saturating_sub(1))
                .min(size.saturating_sub(1));
            if a > b || a >= size {
                return respond(
                    &mut stream,
                    "416 Range Not Satisfiable",
                    "text/plain",
                    b"",
                    "",
                );
            }
            let mut buf = vec![0u8; (b - a + 1).min(64 << 20) as usize];
            f.seek(SeekFrom::Start(a))?;
            f.read_exact(&mut buf)?;
            let extra = format!(
                "Content-Range: bytes {a}-{}/{size}\r\nAccept-Ranges: bytes\r\n",
                a + buf.len() as u64 - 1
            );
            let code = if range.is_some() {
                "206 Partial Content"
            } else {
                "200 OK"
            };
            return respond(&mut stream, code, "application/octet-stream", &buf, &extra);
        }
    }
    if let Some(rest) = path.strip_prefix("/tiles/") {
        let parts: Vec<&str> = rest.trim_end_matches(".png").split('/').collect();
        if let [z, x, y] = parts[..] {
            if let (Ok(z), Ok(x), Ok(y)) = (z.parse::<u8>(), x.parse::<u32>(), y.parse::<u32>()) {
                let data = site.source.tile(z, x, y);
                if let Some(d) = data {
                    return respond(&mut stream, "200 OK", "image/png", &d, "");
                }
                // Missing tiles are empty (transparent), not errors.
                return respond(&mut stream, "204 No Content", "image/png", b"", "");
            }
        }
    }
    respond(&mut stream, "404 Not Found", "text/plain", b"not found", "")
}
