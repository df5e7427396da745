//! Packing a `z/x/y.png` tile folder into an MBTiles file (SQLite, MBTiles
//! 1.3 specification: TMS row order, `metadata` and `tiles` tables) and a
//! PMTiles v3 archive (the `pmtiles` crate; tiles added in increasing
//! Hilbert tile id, as the format wants for clustered archives). Tiles are
//! visited in tile-id order, so both files are the same bytes on every run.

use super::pyramid::PyramidInfo;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The tiles of a pyramid folder as (z, x, y, path), in PMTiles tile-id order.
pub fn list_tiles(dir: &Path, info: &PyramidInfo) -> Result<Vec<(u8, u32, u32, PathBuf)>> {
    let mut out = vec![];
    for z in info.min_zoom..=info.max_zoom {
        let zd = dir.join(z.to_string());
        let Ok(xs) = std::fs::read_dir(&zd) else {
            continue;
        };
        for xe in xs.flatten() {
            let Some(x) = xe.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
                continue;
            };
            let ys = std::fs::read_dir(xe.path()).map_err(|e| Error::io(xe.path(), e))?;
            for ye in ys.flatten() {
                let name = ye.file_name();
                let Some(y) = name
                    .to_str()
                    .and_then(|s| s.strip_suffix(".png"))
                    .and_then(|s| s.parse::<u32>().ok())
                else {
                    continue;
                };
                out.push((z, x, y, ye.path()));
            }
        }
    }
    out.sort_by_key(|t| {
        pmtiles::TileCoord::new(t.0, t.1, t.2)
            .map(|c| pmtiles::TileId::from(c).value())
            .unwrap_or(u64::MAX)
    });
    Ok(out)
}

fn metadata_json(info: &PyramidInfo) -> String {
    serde_json::json!({
        "name": "orogen",
        "format": "png",
        "encoding": info.encoding,
        "bounds": info.bounds,
        "minzoom": info.min_zoom,
        "maxzoom": info.max_zoom,
    })
    .to_string()
}

/// Write the folder's tiles as an MBTiles file at `path` (replaced atomically).
pub fn write_mbtiles(dir: &Path, info: &PyramidInfo, path: &Path) -> Result<u64> {
    let tmp = path.with_extension("mbtiles.tmp");
    let _ = std::fs::remove_file(&tmp);
    let sql = |e: rusqlite::Error| Error::invalid(format!("{}: SQLite: {e}", path.display()));
    let mut db = rusqlite::Connection::open(&tmp).map_err(sql)?;
    db.execute_batch(
        "PRAGMA journal_mode=OFF; PRAGMA synchronous=OFF;
         CREATE TABLE metadata (name TEXT, value TEXT);
         CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, tile_data BLOB);
         CREATE UNIQUE INDEX tile_index ON tiles (zoom_level, tile_column, tile_row);",
    )
    .map_err(sql)?;
    let tiles = list_tiles(dir, info)?;
    let tx = db.transaction().map_err(sql)?;
    {
        let b = info.bounds;
        let center = format!(
            "{},{},{}",
            (b[0] + b[2]) / 2.0,
            (b[1] + b[3]) / 2.0,
            (info.min_zoom as u32 + info.max_zoom as u32) / 2
        );
        let meta = [
            ("name", "orogen".to_string()),
            ("format", "png".to_string()),
            ("type", "baselayer".to_string()),
            ("version", "1.3".to_string()),
            ("bounds", format!("{},{},{},{}", b[0], b[1], b[2], b[3])),
            ("center", center),
            ("minzoom", info.min_zoom.to_string()),
            ("maxzoom", info.max_zoom.to_string()),
            ("json", metadata_json(info)),
        ];
        let mut st = tx
            .prepare("INSERT INTO metadata (name, value) VALUES (?1, ?2)")
            .map_err(sql)?;
        for (k, v) in meta {
            st.execute(rusqlite::params![k, v]).map_err(sql)?;
        }
        let mut st = tx
            .prepare("INSERT INTO tiles (zoom_level, tile_column, tile_row, tile_data) VALUES (?1, ?2, ?3, ?4)")
            .map_err(sql)?;
        for (z, x, y, p) in &tiles {
            let data = std::fs::read(p).map_err(|e| Error::io(p, e))?;
            // MBTiles rows count from the south (TMS).
            let row = (1u64 << z) - 1 - *y as u64;
            st.execute(rusqlite::params![*z as i64, *x as i64, row as i64, data])
                .map_err(sql)?;
        }
    }
    tx.commit().map_err(sql)?;
    db.close().map_err(|(_, e)| sql(e))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))?;
    Ok(tiles.len() as u64)
}

/// Write the folder's tiles as a PMTiles v3 archive at `path` (replaced atomically).
pub fn write_pmtiles(dir: &Path, info: &PyramidInfo, path: &Path) -> Result<u64> {
    let tmp = path.with_extension("pmtiles.tmp");
    let pm = |e: pmtiles::PmtError| Error::invalid(format!("{}: PMTiles: {e}", path.display()));
    let f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let b = info.bounds;
    let mut w = pmtiles::PmTilesWriter::new(pmtiles::TileType::Png)
        .min_zoom(info.min_zoom)
        .max_zoom(info.max_zoom)
        .bounds(b[0], b[1], b[2], b[3])
        .center((b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0)
        .center_zoom(((info.min_zoom as u32 + info.max_zoom as u32) / 2) as u8)
        .metadata(metadata_json(info))
        .create(std::io::BufWriter::new(f))
        .map_err(pm)?;
    let tiles = list_tiles(dir, info)?;
    for (z, x, y, p) in &tiles {
        let data = std::fs::read(p).map_err(|e| Error::io(p, e))?;
        w.add_tile(pmtiles::TileCoord::new(*z, *x, *y).map_err(pm)?, &data)
            .map_err(pm)?;
    }
    w.finalize().map_err(pm)?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))?;
    Ok(tiles.len() as u64)
}
