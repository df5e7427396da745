//! Streaming tiled GeoTIFF writer.
//!
//! The TIFF structure is written by hand: the `tiff` crate (0.11) cannot write
//! tiled, zstd-compressed, floating-point-predicted or streamed files, nor put
//! the IFD before the pixel data (see CRATES.md). Layout (TIFF 6.0 sections 2
//! and 15, BigTIFF as specified by Aware Systems / libtiff):
//!
//! ```text
//! header | IFD + out-of-line tag values (TileOffsets/TileByteCounts as
//!          fixed-size placeholders) | tile data in block order
//! ```
//!
//! The placeholders are patched in [`TileSink::finish`]. Putting directories
//! first is what a Cloud-Optimized GeoTIFF needs; overview IFDs can be added
//! by encoding more directories with [`encode_ifd`] before the data.
//!
//! Compression: DEFLATE (zlib stream, code 8) with `flate2`, LZW (code 5, MSB
//! first, with the TIFF "early change" code-size switch) with `weezl`, ZSTD
//! (code 50000) with `zstd`. Predictors: 2 = horizontal differencing of
//! samples (TIFF 6.0 section 14), 3 = floating point (Adobe TIFF Technical
//! Note 3: each row's values split into byte planes, most significant first,
//! then byte-wise horizontal differencing).

use super::ifd::{encode_ifd, geo_entries, image_entries, Entry};
use super::rows::RowBuffer;
use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, DType, GeoRef, TileId, Window};
use crate::store::sink::TileSink;
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Compression of the written tiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// No compression (code 1).
    None,
    /// DEFLATE / zlib (code 8), level 1-9.
    Deflate { level: u32 },
    /// LZW (code 5).
    Lzw,
    /// Zstandard (code 50000), level 1-22.
    Zstd { level: i32 },
}

impl Compression {
    /// TIFF compression code.
    pub fn code(self) -> u16 {
        match self {
            Compression::None => 1,
            Compression::Lzw => 5,
            Compression::Deflate { .. } => 8,
            Compression::Zstd { .. } => 50000,
        }
    }
}

/// Options of [`GeoTiffWriter`].
#[derive(Debug, Clone)]
pub struct WriteOptions {
    /// Tile compression.
    pub compression: Compression,
    /// TIFF predictor (1 none, 2 horizontal, 3 floating point); None = 2 for
    /// integers and 3 for floats. Uncompressed files never get a predictor
    /// (libtiff and GDAL ignore it there), whatever is asked.
    pub predictor: Option<u16>,
    /// Tile size in cells (multiple of 16).
    pub block: usize,
    /// BigTIFF; None = when the uncompressed size bound could exceed ~4 GiB.
    pub bigtiff: Option<bool>,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            compression: Compression::Deflate { level: 6 },
            predictor: None,
            block: 256,
            bigtiff: None,
        }
    }
}

/// Apply predictor 2 (horizontal differencing of `size`-byte samples) to one row.
fn predict_horizontal(row: &mut [u8], size: usize) {
    macro_rules! diff {
        ($t:ty) => {{
            let n = row.len() / size;
            for i in (1..n).rev() {
                let a = <$t>::from_le_bytes(
                    row[i * size..(i + 1) * size].try_into().unwrap_or_default(),
                );
                let b = <$t>::from_le_bytes(
                    row[(i - 1) * size..i * size].try_into().unwrap_or_default(),
                );
                row[i * size..(i + 1) * size].copy_from_slice(&a.wrapping_sub(b).to_le_bytes());
            }
        }};
    }
    match size {
        1 => {
            for i in (1..row.len()).rev() {
                row[i] = row[i].wrapping_sub(row[i - 1]);
            }
        }
        2 => diff!(u16),
        4 => diff!(u32),
        _ => diff!(u64),
    }
}

/// Apply predictor 3 (TIFF Technical Note 3) to one row of little-endian
/// floats of `size` bytes, using `tmp` as scratch.
fn predict_float(row: &mut [u8], size: usize, tmp: &mut Vec<u8>) {
    let n = row.len() / size;
    tmp.clear();
    tmp.resize(row.len(), 0);
    for i in 0..n {
        for j in 0..size {
            // plane j holds byte j of the big-endian value = byte size-1-j of LE.
            tmp[j * n + i] = row[i * size + size - 1 - j];
        }
    }
    for k in (1..tmp.len()).rev() {
        tmp[k] = tmp[k].wrapping_sub(tmp[k - 1]);
    }
    row.copy_from_slice(tmp);
}

/// Cut a band of `rows` full-width rows (`width` cells of `size` bytes) into
/// `block` x `block` tiles padded with `pad`, and predict and compress them in
/// parallel; returns the encoded blocks left to right.
#[allow(clippy::too_many_arguments)]
pub(super) fn encode_band(
    band: &[u8],
    rows: usize,
    width: usize,
    size: usize,
    block: usize,
    pad: &[u8],
    predictor: u16,
    compression: Compression,
) -> Result<Vec<Vec<u8>>> {
    let row_bytes = width * size;
    (0..width.div_ceil(block))
        .into_par_iter()
        .map(|bx| {
            let x0 = bx * block;
            let cols = block.min(width - x0);
            let mut data = Vec::with_capacity(block * block * size);
            for r in 0..block {
                if r < rows {
                    let s = r * row_bytes + x0 * size;
                    data.extend_from_slice(&band[s..s + cols * size]);
                    for _ in cols..block {
                        data.extend_from_slice(pad);
                    }
                } else {
                    for _ in 0..block {
                        data.extend_from_slice(pad);
                    }
                }
            }
            encode_block(data, block, size, predictor, compression)
        })
        .collect()
}

/// Predict and compress one block (`data` = block x block cells, LE bytes).
pub(super) fn encode_block(
    mut data: Vec<u8>,
    block: usize,
    size: usize,
    predictor: u16,
    compression: Compression,
) -> Result<Vec<u8>> {
    let row_bytes = block * size;
    match predictor {
        2 => data
            .chunks_mut(row_bytes)
            .for_each(|r| predict_horizontal(r, size)),
        3 => {
            let mut tmp = Vec::new();
            data.chunks_mut(row_bytes)
                .for_each(|r| predict_float(r, size, &mut tmp));
        }
        _ => {}
    }
    let err = |e: std::io::Error| Error::invalid(format!("compression failed: {e}"));
    Ok(match compression {
        Compression::None => data,
        Compression::Deflate { level } => {
            let mut enc =
                flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(level.min(9)));
            enc.write_all(&data).map_err(err)?;
            enc.finish().map_err(err)?
        }
        Compression::Lzw => weezl::encode::Encoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8)
            .encode(&data)
            .map_err(|e| Error::invalid(format!("LZW compression failed: {e}")))?,
        Compression::Zstd { level } => zstd::bulk::compress(&data, level).map_err(err)?,
    })
}

/// Remove temporary files that an earlier, killed writer of the same output
/// left next to it (`.NAME.orogen-*-PID` whose process no longer runs).
pub(super) fn clean_stale_temps(path: &Path) {
    use crate::io::atomic::{hidden_prefix, remove_dead};
    if let Some((dir, prefix)) = hidden_prefix(path, "orogen-") {
        remove_dead(dir, |n| {
            n.strip_prefix(prefix.as_str())
                .and_then(|rest| rest.rsplit('-').next())
        });
    }
}

/// The checks both writers make before creating a file: the size fits a
/// TIFF (each side 1..2^32-1), the block size is valid, the predictor suits
/// `dtype` and the nodata value can be stored in it. Returns the predictor.
/// The most memory a GeoTIFF writer may need for its strip and tile tables
/// (4 GiB: a 100000-cell-wide float64 raster at 256-row blocks needs 0.4).
pub const MAX_WRITER_BUFFERS: u64 = 4 << 30;

pub(super) fn check_create(
    path: &Path,
    width: usize,
    height: usize,
    dtype: DType,
    georef: &GeoRef,
    opts: &WriteOptions,
) -> Result<u16> {
    if width == 0 || height == 0 || width > u32::MAX as usize || height > u32::MAX as usize {
        return Err(Error::invalid(format!(
            "{}: cannot write a {width} x {height} raster (each side must be 1..2^32-1)",
            path.display()
        )));
    }
    let block = opts.block;
    if block == 0 || !block.is_multiple_of(16) || block > 1 << 15 {
        return Err(Error::invalid(format!(
            "block size {block} must be a positive multiple of 16 (at most 32768)"
        )));
    }
    // The writer holds one strip of `block` rows (and its encoded copy) and
    // the offset and byte-count tables of every tile: refuse, before any
    // allocation, a raster whose buffers alone would not fit a machine.
    let strip = width as u128 * block as u128 * dtype.size() as u128;
    let tiles = width.div_ceil(block) as u128 * height.div_ceil(block) as u128;
    let need = 2 * strip + 32 * tiles;
    if need > MAX_WRITER_BUFFERS as u128 {
        return Err(Error::invalid(format!(
            "{}: a {width} x {height} {dtype} GeoTIFF needs {:.1} GiB of write buffers (a strip of \
             {block} rows and the tables of {tiles} tiles; at most {} GiB): write a tile store \
             (.tiles) or a smaller raster",
            path.display(),
            need as f64 / (1u64 << 30) as f64,
            MAX_WRITER_BUFFERS >> 30
        )));
    }
    let predictor = resolve_predictor(opts, dtype)?;
    if let Some(nd) = georef.nodata {
        if !dtype.represents(nd) && !nd.is_nan() {
            return Err(Error::invalid(format!(
                "{}: nodata value {nd} cannot be stored in {dtype}",
                path.display()
            )));
        }
    }
    Ok(predictor)
}

/// The predictor written for `dtype` under `opts` (automatic choice: 2 for
/// integers, 3 for floats; none when uncompressed, as libtiff and GDAL only
/// apply predictors inside compression codecs).
pub(super) fn resolve_predictor(opts: &WriteOptions, dtype: DType) -> Result<u16> {
    let predictor = match opts.predictor {
        Some(p @ (1 | 2)) => p,
        Some(3) if dtype.is_float() => 3,
        Some(p) => {
            return Err(Error::invalid(format!(
                "predictor {p} is not valid for {dtype}: use 1 or 2 (3 only for float32/float64)"
            )))
        }
        None if dtype.is_float() => 3,
        None => 2,
    };
    Ok(if opts.compression == Compression::None {
        1
    } else {
        predictor
    })
}

/// A tiled GeoTIFF being written: a [`TileSink`] fed with the engine's tiles
/// (any tile size) in increasing tile id order. Rows are buffered until a row
/// of blocks is complete (at most one block row plus one band of engine
/// tiles); each complete block row is compressed in parallel and written in
/// block order, so the bytes depend neither on the engine's tile size nor on
/// the thread count. Data goes to a temporary file renamed on `finish`; it is
/// removed on error or when the writer is dropped unfinished.
pub struct GeoTiffWriter {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<BufWriter<File>>,
    width: usize,
    height: usize,
    dtype: DType,
    nodata: Option<f64>,
    compression: Compression,
    predictor: u16,
    bigtiff: bool,
    block: usize,
    blocks_y: usize,
    offsets: Vec<u64>,
    counts: Vec<u64>,
    offsets_at: u64,
    counts_at: u64,
    pos: u64,
    rows: RowBuffer,
    next_block_row: usize,
    pad: Vec<u8>,
    finished: bool,
}

impl GeoTiffWriter {
    /// Start writing a `width` x `height` raster of `dtype` to `path`.
    pub fn create(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        dtype: DType,
        georef: &GeoRef,
        opts: &WriteOptions,
    ) -> Result<GeoTiffWriter> {
        let path = path.as_ref().to_path_buf();
        let predictor = check_create(&path, width, height, dtype, georef, opts)?;
        let block = opts.block;
        let blocks_x = width.div_ceil(block);
        let blocks_y = height.div_ceil(block);
        let n_blocks = blocks_x * blocks_y;
        let size = dtype.size();
        let bigtiff = opts.bigtiff.unwrap_or_else(|| {
            let raw = (n_blocks as f64) * (block * block * size) as f64;
            let factor = if opts.compression == Compression::Lzw {
                1.5
            } else {
                1.01
            };
            raw * factor + (n_blocks as f64) * 16.0 + 65536.0 > 4.0e9
        });

        let mut entries = image_entries(
            width,
            height,
            dtype,
            opts.compression.code(),
            block,
            predictor,
            Entry::placeholder(324, n_blocks, bigtiff),
            Entry::placeholder(325, n_blocks, bigtiff),
        );
        entries.extend(geo_entries(georef));
        let header_len = if bigtiff { 16 } else { 8 };
        let (ifd, positions) = encode_ifd(&mut entries, header_len, bigtiff, 0);
        let at = |tag: u16| {
            entries
                .iter()
                .position(|e| e.tag == tag)
                .map(|i| positions[i])
                .unwrap_or(0)
        };
        let offsets_at = at(324);
        let counts_at = at(325);

        let file_name = path
            .file_name()
            .ok_or_else(|| Error::invalid(format!("{}: not a file path", path.display())))?
            .to_string_lossy()
            .into_owned();
        clean_stale_temps(&path);
        let tmp = path.with_file_name(format!(".{file_name}.orogen-tmp-{}", std::process::id()));
        let f = File::create(&tmp).at(&tmp)?;
        let mut w = GeoTiffWriter {
            path,
            tmp,
            file: Some(BufWriter::with_capacity(1 << 20, f)),
            width,
            height,
            dtype,
            nodata: georef.nodata,
            compression: opts.compression,
            predictor,
            bigtiff,
            block,
            blocks_y,
            offsets: Vec::with_capacity(n_blocks),
            counts: Vec::with_capacity(n_blocks),
            offsets_at,
            counts_at,
            pos: 0,
            rows: RowBuffer::new(width, height, dtype),
            next_block_row: 0,
            pad: AnyGrid::filled(dtype, 1, 1, georef.nodata.unwrap_or(0.0))
                .as_le_bytes()
                .to_vec(),
            finished: false,
        };
        let mut head = Vec::with_capacity(16);
        if bigtiff {
            head.extend_from_slice(b"II");
            head.extend_from_slice(&43u16.to_le_bytes());
            head.extend_from_slice(&8u16.to_le_bytes());
            head.extend_from_slice(&0u16.to_le_bytes());
            head.extend_from_slice(&16u64.to_le_bytes());
        } else {
            head.extend_from_slice(b"II");
            head.extend_from_slice(&42u16.to_le_bytes());
            head.extend_from_slice(&8u32.to_le_bytes());
        }
        w.put(&head)?;
        w.put(&ifd)?;
        Ok(w)
    }

    /// True when the file is written as BigTIFF (asked for, or chosen by the
    /// automatic size bound).
    pub fn is_bigtiff(&self) -> bool {
        self.bigtiff
    }

    /// The predictor actually written (after the automatic choice).
    pub fn predictor(&self) -> u16 {
        self.predictor
    }

    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        let f = self
            .file
            .as_mut()
            .ok_or_else(|| Error::invalid("GeoTIFF writer already finished"))?;
        f.write_all(bytes).at(&self.tmp)?;
        self.pos += bytes.len() as u64;
        Ok(())
    }

    /// Compress and write every complete row of blocks still buffered.
    fn flush_complete(&mut self) -> Result<()> {
        let row_bytes = self.width * self.dtype.size();
        while self.next_block_row < self.blocks_y {
            let y0 = self.next_block_row * self.block;
            let rows = self.block.min(self.height - y0);
            debug_assert_eq!(y0, self.rows.y0);
            if self.rows.complete() < rows {
                return Ok(());
            }
            let band = &self.rows.buf[..rows * row_bytes];
            let encoded = encode_band(
                band,
                rows,
                self.width,
                self.dtype.size(),
                self.block,
                &self.pad,
                self.predictor,
                self.compression,
            )?;
            for e in encoded {
                if !self.bigtiff && self.pos + e.len() as u64 > u32::MAX as u64 {
                    return Err(Error::too_large(
                        &self.path,
                        "the file grew past 4 GiB, the limit of classic TIFF: write it as BigTIFF",
                    ));
                }
                self.offsets.push(self.pos);
                self.counts.push(e.len() as u64);
                self.put(&e)?;
            }
            self.rows.consume(rows);
            self.next_block_row += 1;
        }
        Ok(())
    }

    fn finish_inner(&mut self) -> Result<()> {
        self.flush_complete()?;
        if self.next_block_row < self.blocks_y {
            let done = self.rows.y0 + self.rows.complete();
            return Err(Error::invalid(format!(
                "{}: only {done} of {} rows were written; the output was discarded",
                self.path.display(),
                self.height
            )));
        }
        let arr = |v: &[u64], big: bool| -> Vec<u8> {
            if big {
                v.iter().flat_map(|x| x.to_le_bytes()).collect()
            } else {
                v.iter().flat_map(|x| (*x as u32).to_le_bytes()).collect()
            }
        };
        let offs = arr(&self.offsets, self.bigtiff);
        let cnts = arr(&self.counts, self.bigtiff);
        let (oat, cat) = (self.offsets_at, self.counts_at);
        let tmp = self.tmp.clone();
        let mut bw = self
            .file
            .take()
            .ok_or_else(|| Error::invalid("GeoTIFF writer already finished"))?;
        bw.flush().at(&tmp)?;
        let mut f = bw
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        f.seek(SeekFrom::Start(oat)).at(&tmp)?;
        f.write_all(&offs).at(&tmp)?;
        f.seek(SeekFrom::Start(cat)).at(&tmp)?;
        f.write_all(&cnts).at(&tmp)?;
        f.sync_all().at(&tmp)?;
        drop(f);
        crate::store::crash::point("tiff", "tmp");
        std::fs::rename(&tmp, &self.path).at(&self.path)?;
        crate::store::crash::point("tiff", "renamed");
        self.finished = true;
        Ok(())
    }
}

impl TileSink for GeoTiffWriter {
    fn dtype(&self) -> DType {
        self.dtype
    }

    fn nodata(&self) -> Option<f64> {
        self.nodata
    }

    fn write(&mut self, _id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        self.rows.put(&self.path, core, &data)?;
        self.flush_complete()
    }

    fn finish(mut self: Box<Self>) -> Result<()> {
        self.finish_inner()
    }
}

impl Drop for GeoTiffWriter {
    fn drop(&mut self) {
        if !self.finished {
            self.file = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write a whole in-memory grid as a tiled GeoTIFF (fed to the writer in
/// bands of one block row).
pub fn write_geotiff(
    path: impl AsRef<Path>,
    grid: &AnyGrid,
    georef: &GeoRef,
    opts: &WriteOptions,
) -> Result<()> {
    let (w, h) = (grid.width(), grid.height());
    let mut wr = Box::new(GeoTiffWriter::create(
        path,
        w,
        h,
        grid.dtype(),
        georef,
        opts,
    )?);
    let band = opts.block.max(1);
    let mut y = 0;
    let mut id = 0;
    while y < h {
        let rows = band.min(h - y);
        let win = Window::new(0, y as i64, w, rows);
        wr.write(id, win, grid.crop(win))?;
        y += rows;
        id += 1;
    }
    wr.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_predictor_matches_technical_note_3_by_hand() {
        // f32 1.0 = 3F800000, 2.0 = 40000000 (big-endian). Byte planes, most
        // significant first: 3F 40 | 80 00 | 00 00 | 00 00; then each byte
        // minus its left neighbour: 3F 01 40 80 00 00 00 00.
        let mut row: Vec<u8> = [1.0f32, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        predict_float(&mut row, 4, &mut Vec::new());
        assert_eq!(row, vec![0x3F, 0x01, 0x40, 0x80, 0x00, 0x00, 0x00, 0x00]);
    }

    #[test]
    fn horizontal_predictor_differences_samples_with_wraparound() {
        let mut row: Vec<u8> = [100i16, 90, -32768, 32767]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        predict_horizontal(&mut row, 2);
        let got: Vec<i16> = row
            .chunks(2)
            .map(|c| i16::from_le_bytes([c[0], c[1]]))
            .collect();
        // 90-100 = -10; -32768-90 wraps to 32678; 32767-(-32768) wraps to -1.
        assert_eq!(got, vec![100, -10, 32678, -1]);
        let mut bytes = vec![5u8, 3, 250];
        predict_horizontal(&mut bytes, 1);
        assert_eq!(bytes, vec![5, 254, 247]);
    }
}
