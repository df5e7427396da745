//! Samples as they are stored, whatever the file's photometric
//! interpretation, as GDAL returns them.
//!
//! The `tiff` crate (0.11.3) decodes for display: it inverts WhiteIsZero
//! samples (uint8 `255 − v`, float `1 − v`, and refuses int16 as an
//! "unknown photometric interpretation"), and it sizes RGB pixels by the
//! photometric samples only, so an RGB file with an extra sample of
//! unspecified meaning (ExtraSamples = 0) is decoded three samples per pixel
//! where four are stored: every row after the first comes out shifted. GDAL
//! returns the stored values of every band in both cases (TIFF 6.0 §3 and
//! §6: the interpretation says how to *display* samples, not what they are).
//!
//! orogen reads elevations, not colours, so the decoder is shown the file
//! with its PhotometricInterpretation (tag 262) read as BlackIsZero: a
//! [`SampleFile`] answers the decoder's reads from the file, with the two
//! bytes of that tag's value replaced. The crate then decodes every sample
//! of a pixel as stored (`Gray` or `Multiband`), and the reader picks the
//! band asked for. The file on disk is never written.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};

/// TIFF 6.0 PhotometricInterpretation values the reader meets.
pub(super) const WHITE_IS_ZERO: u16 = 0;
/// BlackIsZero: samples as stored.
pub(super) const BLACK_IS_ZERO: u16 = 1;
/// YCbCr (JPEG colour, chroma subsampled): refused.
pub(super) const YCBCR: u16 = 6;

/// What the reader needs of one IFD, from its entries: where tag 262's
/// value sits and what it holds (when it is a single SHORT stored in the
/// entry itself), NewSubfileType (254), the size (256, 257) and
/// BitsPerSample (258) when inline.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct IfdHead {
    /// Offset of tag 262's two value bytes, and the value.
    pub(super) photometric: Option<(u64, u16)>,
    /// NewSubfileType (0 when absent): bit 0 reduced resolution, bit 2 mask.
    pub(super) subfile: u64,
    /// ImageWidth, ImageLength (0 when absent or not inline).
    pub(super) width: u64,
    pub(super) height: u64,
    /// BitsPerSample of a one-sample image (0 when not inline).
    pub(super) bits: u64,
}

/// Where tag 262's value sits in the first IFD and what it holds, from the
/// TIFF header (classic or BigTIFF, either byte order). `None` when the tag
/// is absent or not a single SHORT stored in the entry itself (then the
/// decoder sees the file unchanged).
pub(super) fn find_photometric(f: &mut File) -> io::Result<Option<(u64, u16, bool)>> {
    let (heads, big_endian) = ifd_heads(f, 1)?;
    Ok(heads
        .first()
        .and_then(|h| h.photometric)
        .map(|(at, v)| (at, v, big_endian)))
}

/// The heads of the file's first `max` IFDs, in chain order, and whether
/// it is big-endian; an empty list for what is not a TIFF. The walk stops
/// at the first IFD it cannot read (the decoder reports such files).
pub(super) fn ifd_heads(f: &mut File, max: usize) -> io::Result<(Vec<IfdHead>, bool)> {
    f.seek(SeekFrom::Start(0))?;
    let mut head = [0u8; 16];
    let n = read_full(f, &mut head)?;
    let mut out = Vec::new();
    if n < 8 {
        return Ok((out, false));
    }
    let big_endian = match &head[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok((out, false)),
    };
    let u16_at = |b: &[u8]| {
        let a = [b[0], b[1]];
        if big_endian {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    };
    let u64_of = |b: &[u8]| {
        let mut a = [0u8; 8];
        if big_endian {
            a[8 - b.len()..].copy_from_slice(b);
            u64::from_be_bytes(a)
        } else {
            a[..b.len()].copy_from_slice(b);
            u64::from_le_bytes(a)
        }
    };
    let (bigtiff, mut ifd) = match u16_at(&head[2..4]) {
        42 => (false, u64_of(&head[4..8])),
        43 if n == 16 => (true, u64_of(&head[8..16])),
        _ => return Ok((out, big_endian)),
    };
    let (count_len, entry_len, value_at) = if bigtiff { (8, 20, 12) } else { (2, 12, 8) };
    let mut seen = Vec::new();
    while ifd != 0 && out.len() < max && !seen.contains(&ifd) {
        seen.push(ifd);
        f.seek(SeekFrom::Start(ifd))?;
        let mut count = [0u8; 8];
        if read_full(f, &mut count[..count_len])? < count_len {
            break;
        }
        // At most 4096 entries are looked at: a real IFD has a few dozen.
        let declared = u64_of(&count[..count_len]);
        let entries = declared.min(4096) as usize;
        let mut h = IfdHead::default();
        let mut entry = [0u8; 20];
        let mut whole = true;
        for i in 0..entries {
            if read_full(f, &mut entry[..entry_len])? < entry_len {
                whole = false;
                break;
            }
            let (tag, ty, n) = (
                u16_at(&entry[..2]),
                u16_at(&entry[2..4]),
                u64_of(&entry[4..value_at]),
            );
            // An inline SHORT or LONG (LONG8 in BigTIFF) single value.
            let inline = match (ty, n) {
                (3, 1) => Some(u16_at(&entry[value_at..]) as u64),
                (4, 1) => Some(u64_of(&entry[value_at..value_at + 4])),
                (16, 1) if bigtiff => Some(u64_of(&entry[value_at..value_at + 8])),
                _ => None,
            };
            match tag {
                262 if ty == 3 && n == 1 => {
                    let at = ifd + count_len as u64 + (i * entry_len + value_at) as u64;
                    h.photometric = Some((at, u16_at(&entry[value_at..])));
                }
                254 => h.subfile = inline.unwrap_or(0),
                256 => h.width = inline.unwrap_or(0),
                257 => h.height = inline.unwrap_or(0),
                258 => h.bits = inline.unwrap_or(0),
                _ => {}
            }
        }
        out.push(h);
        if !whole || declared > 4096 {
            break;
        }
        let mut next = [0u8; 8];
        let len = if bigtiff { 8 } else { 4 };
        if read_full(f, &mut next[..len])? < len {
            break;
        }
        ifd = u64_of(&next[..len]);
    }
    Ok((out, big_endian))
}

/// Read until `buf` is full or the file ends; the bytes read.
fn read_full(f: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// A TIFF file as the decoder sees it: the file's bytes, but for the two at
/// `patch.0`, read as `patch.1` (see the module documentation).
pub(super) struct SampleFile {
    file: File,
    pos: u64,
    patch: Option<(u64, [u8; 2])>,
}

impl SampleFile {
    /// `file` as it is on disk.
    pub(super) fn plain(file: File) -> Self {
        SampleFile {
            file,
            pos: 0,
            patch: None,
        }
    }

    /// `file` with the photometric value at `at` read as BlackIsZero.
    pub(super) fn black_is_zero(file: File, at: u64, big_endian: bool) -> Self {
        let v = if big_endian {
            BLACK_IS_ZERO.to_be_bytes()
        } else {
            BLACK_IS_ZERO.to_le_bytes()
        };
        SampleFile {
            file,
            pos: 0,
            patch: Some((at, v)),
        }
    }

    /// The underlying file (metadata).
    pub(super) fn file(&self) -> &File {
        &self.file
    }
}

impl Read for SampleFile {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let start = self.pos;
        let n = self.file.read(buf)?;
        self.pos += n as u64;
        if let Some((at, bytes)) = self.patch {
            for (k, b) in bytes.iter().enumerate() {
                let p = at + k as u64;
                if p >= start && p < start + n as u64 {
                    buf[(p - start) as usize] = *b;
                }
            }
        }
        Ok(n)
    }
}

impl Seek for SampleFile {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        self.pos = self.file.seek(to)?;
        Ok(self.pos)
    }
}
