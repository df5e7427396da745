//! The file as the `tiff` crate is shown it: samples as they are stored,
//! whatever the photometric interpretation, and the tags GDAL tolerates
//! being absent supplied, as GDAL returns them. The file on disk is never
//! written.
//!
//! **Photometric interpretation.** The `tiff` crate (0.11.3) decodes for
//! display: it inverts WhiteIsZero samples (uint8 `255 − v`, float `1 − v`,
//! and refuses int16 as an "unknown photometric interpretation"), and it
//! sizes RGB pixels by the photometric samples only, so an RGB file with an
//! extra sample of unspecified meaning (ExtraSamples = 0) is decoded three
//! samples per pixel where four are stored: every row after the first comes
//! out shifted. GDAL returns the stored values of every band in both cases
//! (TIFF 6.0 §3 and §6: the interpretation says how to *display* samples,
//! not what they are). orogen reads elevations, not colours, so the decoder
//! is shown tag 262 as BlackIsZero: a [`SampleFile`] answers the decoder's
//! reads from the file with the two bytes of that tag's value replaced. The
//! crate then decodes every sample of a pixel as stored (`Gray` or
//! `Multiband`), and the reader picks the band asked for. The same patch
//! shows an internal mask's IFD (PhotometricInterpretation 4) as one-bit
//! gray.
//!
//! **Missing tags.** TIFF 6.0 requires PhotometricInterpretation and
//! StripByteCounts, but real files omit them and libtiff (so GDAL) supplies
//! them: a single-band image without tag 262 is read as BlackIsZero, and a
//! one-strip image without StripByteCounts gets the strip's size (its cells'
//! bytes when uncompressed, the rest of the file otherwise — libtiff's
//! `EstimateStripByteCounts`). The crate refuses both, so the first IFD is
//! shown rebuilt with the missing entries: a copy of its entries plus the
//! new ones, in tag order, placed past the end of the file (word aligned),
//! the header's first-IFD offset patched to point at it. Every offset held
//! by the original entries still points into the real file.

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

/// A TIFF's byte order and offset size, from its header.
#[derive(Debug, Clone, Copy)]
struct Layout {
    big_endian: bool,
    bigtiff: bool,
}

impl Layout {
    fn u16_at(&self, b: &[u8]) -> u16 {
        let a = [b[0], b[1]];
        if self.big_endian {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }
    fn u64_of(&self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        if self.big_endian {
            a[8 - b.len()..].copy_from_slice(b);
            u64::from_be_bytes(a)
        } else {
            a[..b.len()].copy_from_slice(b);
            u64::from_le_bytes(a)
        }
    }
    /// Bytes of the entry count, of one entry, and where an entry's value
    /// field starts.
    fn sizes(&self) -> (usize, usize, usize) {
        if self.bigtiff {
            (8, 20, 12)
        } else {
            (2, 12, 8)
        }
    }
    /// `v` as `n` bytes in the file's order.
    fn bytes(&self, v: u64, n: usize) -> Vec<u8> {
        if self.big_endian {
            v.to_be_bytes()[8 - n..].to_vec()
        } else {
            v.to_le_bytes()[..n].to_vec()
        }
    }
}

/// One IFD entry as stored: tag, type, count, and the raw value field.
#[derive(Debug, Clone)]
struct Entry {
    tag: u16,
    ty: u16,
    count: u64,
    raw: Vec<u8>,
    /// Offset of the value field in the file.
    value_at: u64,
}

impl Entry {
    /// The value when it is one SHORT, LONG or LONG8 held in the entry.
    fn inline(&self, l: &Layout) -> Option<u64> {
        let v = &self.raw[l.sizes().2..];
        match (self.ty, self.count) {
            (3, 1) => Some(l.u16_at(v) as u64),
            (4, 1) => Some(l.u64_of(&v[..4])),
            (16, 1) if l.bigtiff => Some(l.u64_of(&v[..8])),
            _ => None,
        }
    }
}

/// The header's layout and first-IFD offset (with where that offset sits);
/// `None` for what is not a TIFF.
fn header(f: &mut File) -> io::Result<Option<(Layout, u64, u64)>> {
    f.seek(SeekFrom::Start(0))?;
    let mut head = [0u8; 16];
    let n = read_full(f, &mut head)?;
    if n < 8 {
        return Ok(None);
    }
    let big_endian = match &head[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return Ok(None),
    };
    let l = Layout {
        big_endian,
        bigtiff: false,
    };
    Ok(match l.u16_at(&head[2..4]) {
        42 => Some((l, 4, l.u64_of(&head[4..8]))),
        43 if n == 16 => Some((
            Layout {
                big_endian,
                bigtiff: true,
            },
            8,
            l.u64_of(&head[8..16]),
        )),
        _ => None,
    })
}

/// The entries of the IFD at `ifd` (at most 4096 looked at: a real IFD has
/// a few dozen), the next IFD's offset, and whether it was read whole.
fn read_ifd(f: &mut File, l: &Layout, ifd: u64) -> io::Result<(Vec<Entry>, u64, bool)> {
    let (count_len, entry_len, value_at) = l.sizes();
    f.seek(SeekFrom::Start(ifd))?;
    let mut count = [0u8; 8];
    if read_full(f, &mut count[..count_len])? < count_len {
        return Ok((Vec::new(), 0, false));
    }
    let declared = l.u64_of(&count[..count_len]);
    let mut entries = Vec::new();
    for i in 0..declared.min(4096) as usize {
        let mut e = vec![0u8; entry_len];
        if read_full(f, &mut e)? < entry_len {
            return Ok((entries, 0, false));
        }
        entries.push(Entry {
            tag: l.u16_at(&e[..2]),
            ty: l.u16_at(&e[2..4]),
            count: l.u64_of(&e[4..value_at]),
            value_at: ifd + count_len as u64 + (i * entry_len + value_at) as u64,
            raw: e,
        });
    }
    if declared > 4096 {
        return Ok((entries, 0, false));
    }
    let len = if l.bigtiff { 8 } else { 4 };
    let mut next = [0u8; 8];
    if read_full(f, &mut next[..len])? < len {
        return Ok((entries, 0, false));
    }
    Ok((entries, l.u64_of(&next[..len]), true))
}

/// The heads of the file's first `max` IFDs, in chain order, and whether
/// it is big-endian; an empty list for what is not a TIFF. The walk stops
/// at the first IFD it cannot read (the decoder reports such files).
pub(super) fn ifd_heads(f: &mut File, max: usize) -> io::Result<(Vec<IfdHead>, bool)> {
    let mut out = Vec::new();
    let Some((l, _, mut ifd)) = header(f)? else {
        return Ok((out, false));
    };
    let mut seen = Vec::new();
    while ifd != 0 && out.len() < max && !seen.contains(&ifd) {
        seen.push(ifd);
        let (entries, next, whole) = read_ifd(f, &l, ifd)?;
        let mut h = IfdHead::default();
        for e in &entries {
            let inline = e.inline(&l);
            match e.tag {
                262 if e.ty == 3 && e.count == 1 => {
                    h.photometric = Some((e.value_at, l.u16_at(&e.raw[l.sizes().2..])));
                }
                254 => h.subfile = inline.unwrap_or(0),
                256 => h.width = inline.unwrap_or(0),
                257 => h.height = inline.unwrap_or(0),
                258 => h.bits = inline.unwrap_or(0),
                _ => {}
            }
        }
        out.push(h);
        if !whole {
            break;
        }
        ifd = next;
    }
    Ok((out, l.big_endian))
}

/// What the decoder is shown instead of some of the file's bytes: patched
/// byte ranges, and bytes past the end of the file (a rebuilt first IFD).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct View {
    patches: Vec<(u64, Vec<u8>)>,
    /// Where the virtual bytes start (at or past the file's end) and them.
    tail: Option<(u64, Vec<u8>)>,
    big_endian: bool,
}

impl View {
    /// True for a big-endian file.
    pub(super) fn big_endian(&self) -> bool {
        self.big_endian
    }

    /// This view with the PhotometricInterpretation value at `at` read as
    /// BlackIsZero.
    pub(super) fn black_is_zero(mut self, at: u64) -> View {
        let v = if self.big_endian {
            BLACK_IS_ZERO.to_be_bytes()
        } else {
            BLACK_IS_ZERO.to_le_bytes()
        };
        self.patches.push((at, v.to_vec()));
        self
    }
}

/// The view of `f` the decoder needs: for its first IFD, the tags libtiff
/// supplies when absent (see the module documentation), and
/// `photometric_patch` (the photometric value's offset, to read as
/// BlackIsZero). The plain file when nothing is missing.
pub(super) fn file_view(f: &mut File, photometric_patch: Option<u64>) -> io::Result<View> {
    let Some((l, header_at, ifd)) = header(f)? else {
        return Ok(View::default());
    };
    let file_len = f.metadata()?.len();
    let mut view = View {
        big_endian: l.big_endian,
        ..View::default()
    };
    if let Some(at) = photometric_patch {
        view = view.black_is_zero(at);
    }
    let (entries, next, whole) = read_ifd(f, &l, ifd)?;
    if !whole {
        return Ok(view);
    }
    let find = |tag: u16| entries.iter().find(|e| e.tag == tag);
    let inline = |tag: u16| find(tag).and_then(|e| e.inline(&l));
    let (_, entry_len, value_at) = l.sizes();
    let entry = |tag: u16, ty: u16, v: u64| -> Entry {
        let mut raw = Vec::with_capacity(entry_len);
        raw.extend(l.bytes(tag as u64, 2));
        raw.extend(l.bytes(ty as u64, 2));
        raw.extend(l.bytes(1, value_at - 4));
        let size = match ty {
            3 => 2,
            4 => 4,
            _ => 8,
        };
        raw.extend(l.bytes(v, size));
        raw.resize(entry_len, 0);
        Entry {
            tag,
            ty,
            count: 1,
            raw,
            value_at: 0,
        }
    };
    let mut added = Vec::new();
    let samples = inline(277).unwrap_or(1);
    if find(262).is_none() && samples == 1 {
        added.push(entry(262, 3, BLACK_IS_ZERO as u64));
    }
    let strip = find(273).filter(|e| e.count == 1);
    if let (None, Some(strip), None) = (find(279), strip, find(324)) {
        if let Some(offset) = strip.inline(&l) {
            let (w, h) = (inline(256).unwrap_or(0), inline(257).unwrap_or(0));
            let bits = inline(258).unwrap_or(1);
            let bytes = if inline(259).unwrap_or(1) == 1 {
                (w * bits).div_ceil(8) * h * samples
            } else {
                file_len.saturating_sub(offset)
            };
            let ty = if l.bigtiff && bytes > u32::MAX as u64 {
                16
            } else {
                4
            };
            added.push(entry(279, ty, bytes));
        }
    }
    if added.is_empty() {
        return Ok(view);
    }
    let mut all: Vec<Entry> = entries.into_iter().chain(added).collect();
    all.sort_by_key(|e| e.tag);
    let (count_len, _, _) = l.sizes();
    let mut ifd_bytes = l.bytes(all.len() as u64, count_len);
    for e in &all {
        ifd_bytes.extend_from_slice(&e.raw);
    }
    ifd_bytes.extend(l.bytes(next, if l.bigtiff { 8 } else { 4 }));
    let start = file_len + file_len % 2;
    view.patches
        .push((header_at, l.bytes(start, if l.bigtiff { 8 } else { 4 })));
    view.tail = Some((start, ifd_bytes));
    Ok(view)
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

/// A TIFF file as the decoder sees it: the file's bytes through a [`View`]
/// (see the module documentation).
pub(super) struct SampleFile {
    file: File,
    len: u64,
    pos: u64,
    /// Where the file's own cursor is (a read seeks only when it differs).
    file_pos: u64,
    view: View,
}

impl SampleFile {
    /// `file` through `view`.
    pub(super) fn new(file: File, view: View) -> io::Result<Self> {
        let len = file.metadata()?.len();
        Ok(SampleFile {
            file,
            len,
            pos: 0,
            file_pos: 0,
            view,
        })
    }

    /// The underlying file (metadata).
    pub(super) fn file(&self) -> &File {
        &self.file
    }
}

impl Read for SampleFile {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let start = self.pos;
        let n = match &self.view.tail {
            Some((at, tail)) if start >= self.len => {
                // Past the end: zeros up to the tail, then the tail.
                let mut n = 0;
                for (k, b) in buf.iter_mut().enumerate() {
                    let p = start + k as u64;
                    *b = if p < *at {
                        0
                    } else if let Some(&v) = tail.get((p - at) as usize) {
                        v
                    } else {
                        break;
                    };
                    n = k + 1;
                }
                n
            }
            _ => {
                if self.file_pos != start {
                    self.file.seek(SeekFrom::Start(start))?;
                }
                let n = self.file.read(buf)?;
                self.file_pos = start + n as u64;
                n
            }
        };
        self.pos += n as u64;
        for (at, bytes) in &self.view.patches {
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
        let end = match &self.view.tail {
            Some((at, tail)) => at + tail.len() as u64,
            None => self.len,
        };
        let p = match to {
            SeekFrom::Start(p) => Some(p),
            SeekFrom::Current(d) => self.pos.checked_add_signed(d),
            SeekFrom::End(d) => end.checked_add_signed(d),
        };
        self.pos = p.ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                "seek before the start of the file",
            )
        })?;
        Ok(self.pos)
    }
}
