//! `orogen view`: a localhost viewer for tile pyramids. Serves the tiles
//! (a z/x/y folder, an MBTiles file, or a PMTiles archive with HTTP range
//! requests for the pmtiles.js protocol) and a page showing them as 3D
//! terrain with hillshade in MapLibre GL JS. MapLibre and pmtiles.js come
//! from the npm registry, installed by `tools/viewer_setup.sh` into
//! `tools/node_modules`; nothing is fetched from the internet at view time.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Arguments of `orogen view`.
#[derive(Args, Clone)]
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

enum Source {
    Dir(PathBuf),
    Mbtiles(PathBuf),
    Pmtiles(PathBuf),
}

struct Site {
    source: Source,
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
    let ext = a.tiles.extension().and_then(|e| e.to_str()).unwrap_or("");
    let (source, meta) = match ext {
        "pmtiles" => {
            let meta = pmtiles_metadata(&a.tiles)?;
            (Source::Pmtiles(a.tiles.clone()), meta)
        }
        "mbtiles" => {
            let db = rusqlite::Connection::open_with_flags(
                &a.tiles,
                rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY,
            )
            .with_context(|| format!("opening {}", a.tiles.display()))?;
            let json: String = db
                .query_row("SELECT value FROM metadata WHERE name='json'", [], |r| {
                    r.get(0)
                })
                .with_context(|| {
                    format!(
                        "{}: not an orogen MBTiles file (no json metadata)",
                        a.tiles.display()
                    )
                })?;
            (
                Source::Mbtiles(a.tiles.clone()),
                serde_json::from_str(&json)?,
            )
        }
        _ => {
            let m = a.tiles.join("metadata.json");
            let text = std::fs::read_to_string(&m).with_context(|| {
                format!("{}: not a pyramid folder from `orogen tiles`", m.display())
            })?;
            (Source::Dir(a.tiles.clone()), serde_json::from_str(&text)?)
        }
    };
    // Folder pyramids write min_zoom/max_zoom; archives minzoom/maxzoom.
    let mut meta = meta;
    for (from, to) in [("minzoom", "min_zoom"), ("maxzoom", "max_zoom")] {
        if let Some(v) = meta.get(from).cloned() {
            meta[to] = v;
        }
    }
    let source_js = match source {
        Source::Pmtiles(_) => "url:'pmtiles://'+location.origin+'/data.pmtiles'".to_string(),
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

/// The JSON metadata of a PMTiles v3 archive (header fields at fixed
/// offsets of the 127-byte header; metadata possibly gzip-compressed).
fn pmtiles_metadata(p: &Path) -> Result<serde_json::Value> {
    let mut f = std::fs::File::open(p).with_context(|| format!("opening {}", p.display()))?;
    let mut h = [0u8; 127];
    f.read_exact(&mut h)
        .with_context(|| format!("{}: too short for a PMTiles archive", p.display()))?;
    if &h[0..7] != b"PMTiles" || h[7] != 3 {
        bail!("{}: not a PMTiles v3 archive", p.display());
    }
    let u64at = |o: usize| u64::from_le_bytes(h[o..o + 8].try_into().unwrap_or([0; 8]));
    let (off, len) = (u64at(24), u64at(32));
    if len > 64 << 20 {
        bail!("{}: metadata of {len} bytes is implausible", p.display());
    }
    f.seek(SeekFrom::Start(off))?;
    let mut raw = vec![0u8; len as usize];
    f.read_exact(&mut raw)?;
    let text = if h[97] == 2 {
        let mut s = String::new();
        flate2::read::GzDecoder::new(&raw[..]).read_to_string(&mut s)?;
        s
    } else {
        String::from_utf8(raw)?
    };
    Ok(serde_json::from_str(&text)?)
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
        if let Source::Pmtiles(p) = &site.source {
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
                let data = match &site.source {
                    Source::Dir(d) => std::fs::read(d.join(format!("{z}/{x}/{y}.png"))).ok(),
                    Source::Mbtiles(p) => rusqlite::Connection::open_with_flags(p, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
                        .ok()
                        .and_then(|db| {
                            let row = (1i64 << z) - 1 - y as i64;
                            db.query_row(
                                "SELECT tile_data FROM tiles WHERE zoom_level=?1 AND tile_column=?2 AND tile_row=?3",
                                rusqlite::params![z as i64, x as i64, row],
                                |r| r.get::<_, Vec<u8>>(0),
                            )
                            .ok()
                        }),
                    Source::Pmtiles(_) => None,
                };
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
