//! Cloud-Optimized GeoTIFF writer, streamed in bounded memory.
//!
//! Layout (the COG specification, OGC 21-026, and the rules checked by GDAL's
//! `validate_cloud_optimized_geotiff`):
//!
//! ```text
//! header | structural metadata | IFD full resolution | IFD overview 1 | ...
//!        | tiles of the smallest overview | ... | tiles of overview 1
//!        | tiles of the full resolution
//! ```
//!
//! Each level is tiled, compressed and stored in row-major block order; each
//! block is preceded by its byte count (4 bytes) and followed by a copy of its
//! last 4 bytes, which the structural metadata declares
//! (`BLOCK_LEADER=SIZE_AS_UINT4`, `BLOCK_TRAILER=LAST_4_BYTES_REPEATED`) so
//! that HTTP range readers can fetch a block without its IFD and check it.
//!
//! Overviews halve each side (rounding up) until the level fits one block.
//! They are made while the full resolution streams in: every level keeps one
//! band of block rows and one pending row, encodes complete bands into its own
//! temporary file, and hands each pair of rows, reduced 2x2, to the next
//! level. `finish` writes the header and the directories (all sizes are known
//! by then, so BigTIFF is chosen only when the file needs it) and appends the
//! levels' blocks from the smallest overview to the full resolution. Memory:
//! about two block rows of the full width; disk: the output size once more,
//! temporarily.
//!
//! Overview cells: [`Resampling::Average`] (mean of the valid cells of the
//! 2x2 footprint, nodata when none is valid; integers rounded to nearest) for
//! continuous data, [`Resampling::Nearest`] (the footprint's top-left cell)
//! for classes, codes and angles; [`Resampling::for_kind`] picks one from
//! the output's kind when the user did not.

use super::ifd::{encode_ifd, geo_entries, image_entries, Entry};
use super::rows::RowBuffer;
use super::writer::{check_create, clean_stale_temps, encode_band, WriteOptions};
use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, DType, GeoRef, Grid, OutputKind, TileId, Window};
use crate::store::sink::TileSink;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// How overview cells are made from the level above.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resampling {
    /// Mean of the valid cells of each 2x2 footprint (continuous data).
    Average,
    /// Top-left cell of each 2x2 footprint (classes, codes, directions).
    Nearest,
}

impl Resampling {
    /// The resampling for values of `kind`: the mean for continuous data,
    /// the top-left cell for class codes and for angles (the mean of 350°
    /// and 10° is not 180°).
    pub fn for_kind(kind: OutputKind) -> Resampling {
        match kind {
            OutputKind::Continuous => Resampling::Average,
            OutputKind::Categorical | OutputKind::Angle => Resampling::Nearest,
        }
    }
}

/// The structural metadata GDAL readers look for right after the header.
const GHOST: &str = "LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\nBLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n";

fn ghost_bytes() -> Vec<u8> {
    let mut g = format!(
        "GDAL_STRUCTURAL_METADATA_SIZE={:06} bytes\n{GHOST}",
        GHOST.len()
    )
    .into_bytes();
    if g.len() % 2 == 1 {
        g.push(b' ');
    }
    g
}

/// One resolution level being built.
struct Level {
    width: usize,
    height: usize,
    /// Rows of the current band of blocks (native LE bytes, full width).
    band: Vec<u8>,
    band_rows: usize,
    rows_in: usize,
    /// Row waiting for its partner before going to the next level.
    pending: Option<Vec<f64>>,
    tmp: PathBuf,
    file: Option<BufWriter<File>>,
    /// Offset of each block's data inside `tmp` and its byte count.
    offsets: Vec<u64>,
    counts: Vec<u64>,
    len: u64,
}

/// A Cloud-Optimized GeoTIFF being written: a [`TileSink`] fed in increasing
/// tile id order (any engine tile size; the bytes do not depend on it nor on
/// the thread count).
pub struct CogWriter {
    path: PathBuf,
    dtype: DType,
    georef: GeoRef,
    opts: WriteOptions,
    predictor: u16,
    resampling: Resampling,
    levels: Vec<Level>,
    /// Incoming rows at full width.
    rows: RowBuffer,
    pad: Vec<u8>,
    finished: bool,
}

impl CogWriter {
    /// Start writing a `width` x `height` COG of `dtype` to `path`.
    pub fn create(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        dtype: DType,
        georef: &GeoRef,
        opts: &WriteOptions,
        resampling: Resampling,
    ) -> Result<CogWriter> {
        let path = path.as_ref().to_path_buf();
        let predictor = check_create(&path, width, height, dtype, georef, opts)?;
        let block = opts.block;
        let name = path
            .file_name()
            .ok_or_else(|| Error::invalid(format!("{}: not a file path", path.display())))?
            .to_string_lossy()
            .into_owned();
        clean_stale_temps(&path);
        let (mut w, mut h) = (width, height);
        let mut levels = Vec::new();
        loop {
            let tmp = path.with_file_name(format!(
                ".{name}.orogen-cog{}-{}",
                levels.len(),
                std::process::id()
            ));
            let f = File::create(&tmp).at(&tmp)?;
            levels.push(Level {
                width: w,
                height: h,
                band: Vec::new(),
                band_rows: 0,
                rows_in: 0,
                pending: None,
                tmp,
                file: Some(BufWriter::with_capacity(1 << 20, f)),
                offsets: Vec::new(),
                counts: Vec::new(),
                len: 0,
            });
            if w <= block && h <= block {
                break;
            }
            w = w.div_ceil(2);
            h = h.div_ceil(2);
        }
        Ok(CogWriter {
            path,
            dtype,
            georef: georef.clone(),
            opts: opts.clone(),
            predictor,
            resampling,
            levels,
            rows: RowBuffer::new(width, height, dtype),
            pad: AnyGrid::filled(dtype, 1, 1, georef.nodata.unwrap_or(0.0))
                .as_le_bytes()
                .to_vec(),
            finished: false,
        })
    }

    /// Number of levels (full resolution + overviews).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Feed one full-width row of level `l`.
    fn push_row(&mut self, l: usize, row: &[u8]) -> Result<()> {
        let block = self.opts.block;
        let size = self.dtype.size();
        let (last, width) = {
            let lv = &mut self.levels[l];
            lv.band.extend_from_slice(row);
            lv.band_rows += 1;
            lv.rows_in += 1;
            (lv.rows_in == lv.height, lv.width)
        };
        if self.levels[l].band_rows == block || last {
            self.encode_band(l)?;
        }
        if l + 1 < self.levels.len() {
            let vals = AnyGrid::from_le_bytes(self.dtype, width, 1, row)?
                .to_typed::<f64>(self.georef.nodata)
                .into_vec();
            let pending = self.levels[l].pending.take();
            let reduced = match (pending, last) {
                (Some(a), _) => Some(self.reduce(&a, Some(&vals))),
                (None, true) => Some(self.reduce(&vals, None)),
                (None, false) => {
                    self.levels[l].pending = Some(vals);
                    None
                }
            };
            if let Some(r) = reduced {
                let g = Grid::from_vec(r.len(), 1, r)?;
                let bytes = AnyGrid::from_typed(&g, self.dtype, self.georef.nodata);
                self.push_row(l + 1, bytes.as_le_bytes())?;
            }
        }
        debug_assert!(size > 0);
        Ok(())
    }

    /// One row of the next level from rows `a` and (unless the level has an
    /// odd last row) `b`.
    fn reduce(&self, a: &[f64], b: Option<&[f64]>) -> Vec<f64> {
        let w = a.len();
        let out_w = w.div_ceil(2);
        let mut out = Vec::with_capacity(out_w);
        for i in 0..out_w {
            let (x0, x1) = (2 * i, (2 * i + 1).min(w - 1));
            match self.resampling {
                Resampling::Nearest => out.push(a[x0]),
                Resampling::Average => {
                    let mut sum = 0.0;
                    let mut n = 0u32;
                    let mut add = |v: f64| {
                        if v.is_finite() {
                            sum += v;
                            n += 1;
                        }
                    };
                    add(a[x0]);
                    if x1 != x0 {
                        add(a[x1]);
                    }
                    if let Some(b) = b {
                        add(b[x0]);
                        if x1 != x0 {
                            add(b[x1]);
                        }
                    }
                    out.push(if n == 0 { f64::NAN } else { sum / n as f64 });
                }
            }
        }
        out
    }

    /// Compress the buffered band of level `l` into blocks and append them
    /// (with leader and trailer) to the level's temporary file.
    fn encode_band(&mut self, l: usize) -> Result<()> {
        let (block, size, pred, comp) = (
            self.opts.block,
            self.dtype.size(),
            self.predictor,
            self.opts.compression,
        );
        let lv = &mut self.levels[l];
        let encoded = encode_band(
            &lv.band,
            lv.band_rows,
            lv.width,
            size,
            block,
            &self.pad,
            pred,
            comp,
        )?;
        let f = lv
            .file
            .as_mut()
            .ok_or_else(|| Error::invalid("COG writer already finished"))?;
        for e in encoded {
            let n = e.len();
            if n > u32::MAX as usize {
                return Err(Error::too_large(
                    &lv.tmp,
                    "a compressed block exceeds 4 GiB",
                ));
            }
            let trailer: [u8; 4] = if n >= 4 {
                [e[n - 4], e[n - 3], e[n - 2], e[n - 1]]
            } else {
                [0; 4]
            };
            f.write_all(&(n as u32).to_le_bytes()).at(&lv.tmp)?;
            lv.offsets.push(lv.len + 4);
            lv.counts.push(n as u64);
            f.write_all(&e).at(&lv.tmp)?;
            f.write_all(&trailer).at(&lv.tmp)?;
            lv.len += n as u64 + 8;
        }
        lv.band.clear();
        lv.band_rows = 0;
        Ok(())
    }

    /// The directory entries of level `l` with data offsets `offs` (absolute).
    fn entries(&self, l: usize, offs: &[u64], bigtiff: bool) -> Vec<Entry> {
        let lv = &self.levels[l];
        let mut e = image_entries(
            lv.width,
            lv.height,
            self.dtype,
            self.opts.compression.code(),
            self.opts.block,
            self.predictor,
            Entry::offsets(324, offs, bigtiff),
            Entry::offsets(325, &lv.counts, bigtiff),
        );
        if l > 0 {
            // NewSubfileType: reduced-resolution version of the first image.
            e.push(Entry::long(254, 1));
        }
        if l == 0 {
            e.extend(geo_entries(&self.georef));
        } else if let Some(nd) = self.georef.nodata {
            // GDAL_NODATA on overviews too, as GDAL writes it.
            e.extend(geo_entries(&GeoRef {
                georeferenced: false,
                nodata: Some(nd),
                ..self.georef.clone()
            }));
        }
        e
    }

    /// Header + structural metadata + directories for data starting where
    /// they end; returns the bytes.
    fn directories(&self, bigtiff: bool) -> Vec<u8> {
        let header_len: u64 = if bigtiff { 16 } else { 8 };
        let ghost = ghost_bytes();
        let first_ifd = header_len + ghost.len() as u64;
        // Directory sizes do not depend on the offsets they hold.
        let mut lens = Vec::new();
        for l in 0..self.levels.len() {
            let zeros = vec![0u64; self.levels[l].counts.len()];
            let mut e = self.entries(l, &zeros, bigtiff);
            lens.push(encode_ifd(&mut e, 0, bigtiff, 0).0.len() as u64);
        }
        let data_start = first_ifd + lens.iter().sum::<u64>();
        // Data: smallest overview first, full resolution last.
        let mut base = vec![0u64; self.levels.len()];
        let mut at = data_start;
        for l in (0..self.levels.len()).rev() {
            base[l] = at;
            at += self.levels[l].len;
        }
        let mut out = Vec::new();
        if bigtiff {
            out.extend_from_slice(b"II");
            out.extend_from_slice(&43u16.to_le_bytes());
            out.extend_from_slice(&8u16.to_le_bytes());
            out.extend_from_slice(&0u16.to_le_bytes());
            out.extend_from_slice(&first_ifd.to_le_bytes());
        } else {
            out.extend_from_slice(b"II");
            out.extend_from_slice(&42u16.to_le_bytes());
            out.extend_from_slice(&(first_ifd as u32).to_le_bytes());
        }
        out.extend_from_slice(&ghost);
        let mut start = first_ifd;
        for l in 0..self.levels.len() {
            let offs: Vec<u64> = self.levels[l].offsets.iter().map(|o| o + base[l]).collect();
            let mut e = self.entries(l, &offs, bigtiff);
            let next = if l + 1 < self.levels.len() {
                start + lens[l]
            } else {
                0
            };
            let (bytes, _) = encode_ifd(&mut e, start, bigtiff, next);
            debug_assert_eq!(bytes.len() as u64, lens[l]);
            out.extend_from_slice(&bytes);
            start += lens[l];
        }
        out
    }

    fn finish_inner(&mut self) -> Result<()> {
        self.drain_rows()?;
        let done = self.levels[0].rows_in;
        if done < self.levels[0].height {
            return Err(Error::invalid(format!(
                "{}: only {done} of {} rows were written; the output was discarded",
                self.path.display(),
                self.levels[0].height
            )));
        }
        for lv in &mut self.levels {
            if let Some(f) = lv.file.take() {
                let f = f
                    .into_inner()
                    .map_err(|e| Error::io(&lv.tmp, e.into_error()))?;
                f.sync_all().at(&lv.tmp)?;
            }
        }
        let data: u64 = self.levels.iter().map(|l| l.len).sum();
        let blocks: u64 = self.levels.iter().map(|l| l.counts.len() as u64).sum();
        let bigtiff = self.opts.bigtiff.unwrap_or(
            // Directories hold 8 bytes per block in classic TIFF; keep a margin.
            data + blocks * 8 + (1 << 20) > u32::MAX as u64,
        );
        if !bigtiff && data + blocks * 8 + (1 << 16) > u32::MAX as u64 {
            return Err(Error::too_large(
                &self.path,
                "the COG would pass 4 GiB, the limit of classic TIFF: write it as BigTIFF (--bigtiff yes or auto)",
            ));
        }
        let head = self.directories(bigtiff);
        let name = self
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = self
            .path
            .with_file_name(format!(".{name}.orogen-tmp-{}", std::process::id()));
        let result = (|| -> Result<()> {
            let mut out = BufWriter::with_capacity(1 << 20, File::create(&tmp).at(&tmp)?);
            out.write_all(&head).at(&tmp)?;
            for lv in self.levels.iter().rev() {
                let mut f = File::open(&lv.tmp).at(&lv.tmp)?;
                let mut buf = vec![0u8; 1 << 20];
                loop {
                    let n = f.read(&mut buf).at(&lv.tmp)?;
                    if n == 0 {
                        break;
                    }
                    out.write_all(&buf[..n]).at(&tmp)?;
                }
            }
            let f = out
                .into_inner()
                .map_err(|e| Error::io(&tmp, e.into_error()))?;
            f.sync_all().at(&tmp)?;
            crate::store::crash::point("cog", "tmp");
            std::fs::rename(&tmp, &self.path).at(&self.path)?;
            crate::store::crash::point("cog", "renamed");
            Ok(())
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result?;
        for lv in &self.levels {
            let _ = std::fs::remove_file(&lv.tmp);
        }
        self.finished = true;
        Ok(())
    }

    /// Pass every complete leading row of the input buffer to level 0.
    fn drain_rows(&mut self) -> Result<()> {
        let width = self.levels[0].width;
        let row_bytes = width * self.dtype.size();
        let n = self.rows.complete();
        if n == 0 {
            return Ok(());
        }
        let rows: Vec<u8> = self.rows.buf[..n * row_bytes].to_vec();
        self.rows.consume(n);
        for r in 0..n {
            self.push_row(0, &rows[r * row_bytes..(r + 1) * row_bytes])?;
        }
        Ok(())
    }
}

impl TileSink for CogWriter {
    fn dtype(&self) -> DType {
        self.dtype
    }

    fn nodata(&self) -> Option<f64> {
        self.georef.nodata
    }

    fn write(&mut self, _id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        self.rows.put(&self.path, core, &data)?;
        self.drain_rows()
    }

    fn finish(mut self: Box<Self>) -> Result<()> {
        self.finish_inner()
    }
}

impl Drop for CogWriter {
    fn drop(&mut self) {
        for lv in &mut self.levels {
            lv.file = None;
            let _ = std::fs::remove_file(&lv.tmp);
        }
        let _ = self.finished;
    }
}
