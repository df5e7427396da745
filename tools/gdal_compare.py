#!/usr/bin/env python3
"""Compare orogen's GeoTIFF reading and writing with GDAL's (see gdal_variants.sh).

Modes:
  (default)    build every read variant of real DEMs from ../shared/data with GDAL and
               check `orogen info --json` (transform, EPSG, nodata) and the values orogen
               reads (exported uncompressed, read back by GDAL) against GDAL's reading;
               then check that what orogen WRITES (every option) GDAL reads identically.
  --fixtures   write small crops of every read variant to tests/data/gdal/ with GDAL's
               reference values (raw little-endian .bin) and manifest.json, for cargo test.
  --band-fixtures
               write the multi-band and photometric variants (every band of pixel- and
               band-interleaved files; WhiteIsZero, RGB with unspecified extra samples,
               alpha, palette) to tests/data/gdal/bands/, each band's values as GDAL
               reads them, for cargo test; and a CMYK file orogen refuses.
  --case-fixtures
               write tests/data/gdal/cases/: internal masks and alpha (GDAL's mask band
               recorded), sparse blocks (SPARSE_OK), float16 samples, LERC (plain, with
               DEFLATE, with ZSTD; lossless and lossy), and georeferencing
               GDAL writes its own way (south-up, no CRS, PixelIsPoint without CRS; GCPs and RPCs, which orogen
               names as not used), each
               with band 1 as GDAL reads it, its mask, and the GeoTIFF tags GDAL wrote;
               and the hand-made TIFFs of --cases with GDAL's reading of them.
  --cases      build those cases afresh, and hand-made TIFFs GDAL tolerates (no
               PhotometricInterpretation, no StripByteCounts, old-style LZW, "1.#INF"
               nodata), and compare orogen's read and export round trip with GDAL's
               (values, masks, geotransform, EPSG, nodata); also part of the default mode.
"""
import json, os, shlex, struct, subprocess, sys, tempfile
import numpy as np
from osgeo import gdal

gdal.UseExceptions()
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
OROGEN = shlex.split(os.environ.get("OROGEN", "cargo run --release --bin orogen --"))

SOURCES = {  # dtype -> (file, GDAL type to convert to)
    "int16": ("srtm3_N46E008.tif", gdal.GDT_Int16),      # geographic, PixelIsPoint, voids
    "float32": ("qgis_dem25.tif", gdal.GDT_Float32),     # projected EPSG:23030, nodata -32768
    "float64": ("qgis_dem25.tif", gdal.GDT_Float64),
}
COMPRESSIONS = ["NONE", "LZW", "DEFLATE", "ZSTD"]

passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL:", what, flush=True)


def gdal_facts(path):
    d = gdal.Open(path)
    b = d.GetRasterBand(1)
    srs = d.GetSpatialRef()
    epsg = None
    if srs is not None:
        code = srs.GetAuthorityCode(None)
        epsg = int(code) if code else None
    nd = b.GetNoDataValue()
    arr = b.ReadAsArray()
    if (d.GetMetadataItem("PIXELTYPE", "IMAGE_STRUCTURE") or b.GetMetadataItem("PIXELTYPE", "IMAGE_STRUCTURE")) == "SIGNEDBYTE":
        arr = arr.view(np.int8)
    return {
        "width": d.RasterXSize, "height": d.RasterYSize,
        "transform": list(d.GetGeoTransform()), "epsg": epsg,
        # JSON has no NaN or infinity: GDAL_NODATA's text for them.
        "nodata": None if nd is None else ("nan" if nd != nd else {np.inf: "inf", -np.inf: "-inf"}.get(nd, nd)),
        "raster_type": (d.GetMetadataItem("AREA_OR_POINT") or "Area").lower(),
    }, arr


def orogen(*args):
    r = subprocess.run(OROGEN + list(args), capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr


def same_nodata(a, b):
    if a is None or b is None:
        return a is None and b is None
    if a == "nan" or b == "nan":
        return a == b
    return float(a) == float(b)


def compare_read(path, facts, arr, tmp):
    """orogen's reading of `path` equals GDAL's `facts`/`arr`."""
    name = os.path.basename(path)
    rc, out, err = orogen("info", path, "--json")
    if rc != 0:
        check(False, f"{name}: orogen info failed: {err.strip()}")
        return
    info = json.loads(out)
    check(info["width"] == facts["width"] and info["height"] == facts["height"], f"{name}: size")
    check(info["transform"] == facts["transform"], f"{name}: transform {info['transform']} != {facts['transform']}")
    check(info.get("epsg") == facts["epsg"], f"{name}: EPSG {info.get('epsg')} != {facts['epsg']}")
    check(same_nodata(info.get("nodata"), facts["nodata"]), f"{name}: nodata {info.get('nodata')} != {facts['nodata']}")
    out_tif = os.path.join(tmp, "read_" + name)
    rc, _, err = orogen("export", path, "-o", out_tif, "--compress", "none")
    if rc != 0:
        check(False, f"{name}: orogen export failed: {err.strip()}")
        return
    _, got = gdal_facts(out_tif)
    check(got.dtype == arr.dtype and np.array_equal(got, arr, equal_nan=arr.dtype.kind == "f"), f"{name}: values differ")
    os.remove(out_tif)


def patch_compression(path, code):
    """Rewrite the Compression tag (259) of a classic little-endian TIFF in place
    (used to make the legacy DEFLATE code 32946, which GDAL does not write)."""
    with open(path, "r+b") as f:
        b = f.read(8)
        assert b[:4] == b"II*\0"
        off = struct.unpack("<I", b[4:8])[0]
        f.seek(off)
        n = struct.unpack("<H", f.read(2))[0]
        for i in range(n):
            f.seek(off + 2 + 12 * i)
            tag, typ = struct.unpack("<HH", f.read(4))
            if tag == 259:
                f.seek(off + 2 + 12 * i + 8)
                f.write(struct.pack("<H", code))
                return
    raise RuntimeError("no compression tag")


def read_variants(dtype):
    """(suffix, creation options) of every read variant of a dtype."""
    preds = [1, 2, 3] if dtype.startswith("float") else [1, 2]
    out = []
    for layout in ["strip", "tiled"]:
        for comp in COMPRESSIONS:
            for p in preds if comp != "NONE" else [1]:
                for big in ["classic", "big"]:
                    co = [f"COMPRESS={comp}", f"BIGTIFF={'YES' if big == 'big' else 'NO'}"]
                    if p != 1:
                        co.append(f"PREDICTOR={p}")
                    co += ["TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"] if layout == "tiled" else ["BLOCKYSIZE=5"]
                    out.append((f"{layout}_{comp.lower()}_p{p}_{big}", co))
    return out


def source_dataset(dtype, win=None):
    fname, gtype = SOURCES[dtype]
    opts = dict(format="MEM", outputType=gtype)
    if win:
        opts["srcWin"] = win
    ds = gdal.Translate("", os.path.join(DATA, fname), **opts)
    b = ds.GetRasterBand(1)
    nd = b.GetNoDataValue()
    if win and nd is not None and gtype in (gdal.GDT_Float32, gdal.GDT_Float64):
        # The float crops hold no voids: make a few, so nodata handling is exercised.
        a = b.ReadAsArray()
        yy, xx = np.mgrid[0:a.shape[0], 0:a.shape[1]]
        a[(xx * 7 + yy * 3) % 41 == 0] = nd
        b.WriteArray(a)
    return ds


def find_window(dtype, w=67, h=43):
    """A w x h window holding some (not only) nodata cells."""
    fname, _ = SOURCES[dtype]
    d = gdal.Open(os.path.join(DATA, fname))
    b = d.GetRasterBand(1)
    a = b.ReadAsArray()
    nd = b.GetNoDataValue()
    for y in range(0, d.RasterYSize - h, 7):
        for x in range(0, d.RasterXSize - w, 7):
            n = int((a[y:y + h, x:x + w] == nd).sum())
            if 20 <= n <= w * h // 4:
                return [x, y, w, h]
    return [0, 0, w, h]


def extra_variants(tmp):
    """Other read variants: big-endian, PackBits, DEFLATE 32946, more types, multi-band,
    rotated transform. Yields (file name, dataset to translate, creation options, post-fix)."""
    src = source_dataset("int16", find_window("int16"))
    yield "int16_strip_be_deflate_p2.tif", src, ["COMPRESS=DEFLATE", "PREDICTOR=2", "ENDIANNESS=BIG", "BLOCKYSIZE=5"], None
    yield "int16_tiled_be_none_big.tif", src, ["ENDIANNESS=BIG", "BIGTIFF=YES", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], None
    yield "int16_strip_packbits.tif", src, ["COMPRESS=PACKBITS", "BLOCKYSIZE=5"], None
    yield "int16_tiled_deflate32946_p2.tif", src, ["COMPRESS=DEFLATE", "PREDICTOR=2", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], 32946
    f32 = source_dataset("float32", find_window("float32"))
    # (GDAL 3.6 reads its own big-endian files with PREDICTOR=3 as garbage, so the
    # big-endian float variants use predictors 1 and 2.)
    yield "float32_tiled_be_zstd_p2.tif", f32, ["COMPRESS=ZSTD", "PREDICTOR=2", "ENDIANNESS=BIG", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], None
    yield "float32_strip_be_none_big.tif", f32, ["ENDIANNESS=BIG", "BIGTIFF=YES", "BLOCKYSIZE=5"], None
    f64 = source_dataset("float64", find_window("float64"))
    yield "float64_tiled_be_lzw_p2.tif", f64, ["COMPRESS=LZW", "PREDICTOR=2", "ENDIANNESS=BIG", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], None
    # Other integer types, from the int16 crop (values shifted/clipped to fit).
    a = src.GetRasterBand(1).ReadAsArray().astype(np.int64)
    for name, gtype, conv, co in [
        ("uint8", gdal.GDT_Byte, lambda v: np.clip(v // 20, 0, 255), []),
        ("int8", gdal.GDT_Byte, lambda v: np.clip(v // 40 - 60, -128, 127).astype(np.int8).view(np.uint8), ["PIXELTYPE=SIGNEDBYTE"]),
        ("uint16", gdal.GDT_UInt16, lambda v: np.clip(v + 1000, 0, 65535), []),
        ("int32", gdal.GDT_Int32, lambda v: v * 1000 - 7, []),
        ("uint32", gdal.GDT_UInt32, lambda v: np.clip(v, 0, None) * 70000, []),
    ]:
        d = gdal.GetDriverByName("MEM").Create("", a.shape[1], a.shape[0], 1, gtype)
        d.SetGeoTransform(src.GetGeoTransform())
        d.SetProjection(src.GetProjection())
        d.GetRasterBand(1).WriteArray(conv(a))
        yield f"{name}_strip_lzw_p2.tif", d, ["COMPRESS=LZW", "PREDICTOR=2", "BLOCKYSIZE=5"] + co, None
        yield f"{name}_tiled_deflate_p1.tif", d, ["COMPRESS=DEFLATE", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"] + co, None
    # Pixel-interleaved 2 bands: orogen reads band 1.
    d = gdal.GetDriverByName("MEM").Create("", a.shape[1], a.shape[0], 2, gdal.GDT_Int16)
    d.SetGeoTransform(src.GetGeoTransform())
    d.SetProjection(src.GetProjection())
    d.GetRasterBand(1).WriteArray(a)
    d.GetRasterBand(2).WriteArray(a + 1000)
    d.GetRasterBand(1).SetNoDataValue(-32767)
    yield "int16_2band_pixel_deflate_p2.tif", d, ["COMPRESS=DEFLATE", "PREDICTOR=2", "INTERLEAVE=PIXEL", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], None
    # Rotated transform (ModelTransformation), projected CRS.
    r = gdal.Translate("", f32, format="MEM")
    gt = r.GetGeoTransform()
    r.SetGeoTransform((gt[0], gt[1] * 0.96, gt[1] * 0.28, gt[3], gt[1] * 0.28, gt[5] * 0.96))
    yield "float32_rotated_deflate_p3.tif", r, ["COMPRESS=DEFLATE", "PREDICTOR=3", "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], None
    # No georeferencing at all.
    n = gdal.GetDriverByName("MEM").Create("", a.shape[1], a.shape[0], 1, gdal.GDT_Int16)
    n.GetRasterBand(1).WriteArray(a)
    yield "int16_nogeo_none.tif", n, ["BLOCKYSIZE=5"], None


def band_variants():
    """Multi-band and photometric variants of the int16 crop: (file name, dataset,
    creation options). Every band of each is a reference (GDAL reads stored samples
    whatever the photometric interpretation)."""
    src = source_dataset("int16", find_window("int16"))  # kept alive while its band is read
    a = src.GetRasterBand(1).ReadAsArray().astype(np.int64)
    a = np.where(a < -1000, 0, a)
    h, w = a.shape

    def mem(bands, gtype):
        d = gdal.GetDriverByName("MEM").Create("", w, h, len(bands), gtype)
        for i, v in enumerate(bands):
            d.GetRasterBand(i + 1).WriteArray(v)
        return d

    u8 = [np.clip(a // 20, 0, 255), (a // 3) % 256, 255 - np.clip(a // 20, 0, 255), a % 256, (a * 7) % 256]
    i16 = [a, a - 2000, -a]
    f32 = [(a * 0.5 + 0.25).astype(np.float32), (a * -0.125).astype(np.float32), (a / 3.0).astype(np.float32)]
    tiled = ["TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"]
    yield "u8_miniswhite_strip.tif", mem(u8[:1], gdal.GDT_Byte), ["PHOTOMETRIC=MINISWHITE", "BLOCKYSIZE=5"]
    yield "i16_miniswhite_tiled_deflate.tif", mem(i16[:1], gdal.GDT_Int16), ["PHOTOMETRIC=MINISWHITE", "COMPRESS=DEFLATE"] + tiled
    yield "f32_miniswhite_lzw_p3.tif", mem(f32[:1], gdal.GDT_Float32), ["PHOTOMETRIC=MINISWHITE", "COMPRESS=LZW", "PREDICTOR=3", "BLOCKYSIZE=5"]
    yield "u8_rgb_extra_unspecified_strip.tif", mem(u8[:4], gdal.GDT_Byte), ["PHOTOMETRIC=RGB", "ALPHA=NO", "INTERLEAVE=PIXEL", "BLOCKYSIZE=5"]
    yield "u8_rgb_extra_unspecified_tiled_deflate.tif", mem(u8[:4], gdal.GDT_Byte), ["PHOTOMETRIC=RGB", "ALPHA=NO", "INTERLEAVE=PIXEL", "COMPRESS=DEFLATE"] + tiled
    yield "u8_rgb_two_extra_strip.tif", mem(u8, gdal.GDT_Byte), ["PHOTOMETRIC=RGB", "ALPHA=NO", "INTERLEAVE=PIXEL", "BLOCKYSIZE=5"]
    yield "u16_rgb_alpha_tiled.tif", mem([np.clip(v * 200, 0, 65535) for v in u8[:4]], gdal.GDT_UInt16), ["PHOTOMETRIC=RGB", "ALPHA=YES", "INTERLEAVE=PIXEL"] + tiled
    yield "i16_3band_pixel_strip_lzw_p2.tif", mem(i16, gdal.GDT_Int16), ["INTERLEAVE=PIXEL", "COMPRESS=LZW", "PREDICTOR=2", "BLOCKYSIZE=5"]
    yield "i16_3band_planar_tiled_deflate.tif", mem(i16, gdal.GDT_Int16), ["INTERLEAVE=BAND", "COMPRESS=DEFLATE"] + tiled
    yield "f32_3band_planar_strip_zstd_p3.tif", mem(f32, gdal.GDT_Float32), ["INTERLEAVE=BAND", "COMPRESS=ZSTD", "PREDICTOR=3", "BLOCKYSIZE=5"]
    yield "f32_3band_planar_none_big.tif", mem(f32, gdal.GDT_Float32), ["INTERLEAVE=BAND", "BIGTIFF=YES", "BLOCKYSIZE=5"]
    pal = mem(u8[:1], gdal.GDT_Byte)
    ct = gdal.ColorTable()
    for i in range(256):
        ct.SetColorEntry(i, (i, 255 - i, (i * 3) % 256, 255))
    pal.GetRasterBand(1).SetRasterColorTable(ct)
    yield "u8_palette_strip.tif", pal, ["BLOCKYSIZE=5"]


def empty_fixture_dir(name):
    """tests/data/gdal/NAME, created or emptied."""
    out_dir = os.path.join(ROOT, "tests", "data", "gdal", name)
    os.makedirs(out_dir, exist_ok=True)
    for f in os.listdir(out_dir):
        os.remove(os.path.join(out_dir, f))
    return out_dir


def make_band_fixtures():
    out_dir = empty_fixture_dir("bands")
    manifest = {"files": []}
    for fname, ds, co in band_variants():
        path = os.path.join(out_dir, fname)
        gdal.Translate(path, ds, format="GTiff", creationOptions=co)
        d = gdal.Open(path)
        for b in range(1, d.RasterCount + 1):
            arr = d.GetRasterBand(b).ReadAsArray()
            ref = f"{fname[:-4]}.b{b}.bin"
            np.ascontiguousarray(arr).astype(arr.dtype.newbyteorder("<")).tofile(os.path.join(out_dir, ref))
            e = {"file": fname, "band": b, "bands": d.RasterCount, "width": d.RasterXSize,
                 "height": d.RasterYSize, "dtype": str(arr.dtype), "reference": ref}
            e.update(mask_reference(d.GetRasterBand(b), out_dir, f"{fname[:-4]}.b{b}"))
            manifest["files"].append(e)
    # CMYK colour, which GDAL reads converted to RGBA: not elevations, refused.
    y = gdal.GetDriverByName("MEM").Create("", 16, 8, 4, gdal.GDT_Byte)
    gdal.Translate(os.path.join(out_dir, "refused_cmyk.tif"), y, format="GTiff",
                   creationOptions=["PHOTOMETRIC=CMYK", "INTERLEAVE=PIXEL"])
    with open(os.path.join(out_dir, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    total = sum(os.path.getsize(os.path.join(out_dir, f)) for f in os.listdir(out_dir))
    print(f"wrote {len(manifest['files'])} band references, {total} bytes, to {out_dir}")


def mask_reference(band, out_dir, stem):
    """GDAL's mask of `band` as a .bin (one byte a cell, 0 = masked) when it is a
    per-dataset mask or alpha (not all-valid, not from nodata): {"mask": name}."""
    flags = band.GetMaskFlags()
    if flags & gdal.GMF_ALL_VALID or flags & gdal.GMF_NODATA:
        return {}
    ref = f"{stem}.mask.bin"
    band.GetMaskBand().ReadAsArray().astype(np.uint8).tofile(os.path.join(out_dir, ref))
    return {"mask": ref}


GEO_TAGS = (33550, 33922, 34264, 34735)


def geotiff_tags(path):
    """The georeferencing tags of a little-endian classic TIFF's first IFD, as
    GDAL wrote them: {tag: [values]} (doubles for 33550/33922/34264, shorts for
    the GeoKey directory 34735)."""
    b = open(path, "rb").read()
    assert b[:4] == b"II*\0", path
    off = struct.unpack("<I", b[4:8])[0]
    n = struct.unpack("<H", b[off:off + 2])[0]
    out = {}
    for i in range(n):
        tag, ty, c, v = struct.unpack("<HHII", b[off + 2 + 12 * i:off + 14 + 12 * i])
        if tag in GEO_TAGS:
            size, fmt = {3: (2, "H"), 12: (8, "d")}[ty]
            data = b[v:v + size * c] if size * c > 4 else b[off + 10 + 12 * i:off + 14 + 12 * i]
            out[str(tag)] = list(struct.unpack(f"<{c}{fmt}", data[:size * c]))
    return out


def case_variants():
    """(file name, writer) pairs of tests/data/gdal/cases: each writer makes the file."""
    w, h = 37, 29
    base = (np.arange(w * h).reshape(h, w) % 500).astype(np.float64)
    hole = np.full((h, w), 255, np.uint8)
    hole[5:12, 3:20] = 0
    hole[20:, 30:] = 0
    gt = [500000.0, 10.0, 0.0, 5200000.0, 0.0, -10.0]

    def create(path, gtype, co, bands=1, srs=32633, transform=gt):
        d = gdal.GetDriverByName("GTiff").Create(path, w, h, bands, gtype, co)
        d.SetGeoTransform(transform)
        if srs:
            from osgeo import osr
            r = osr.SpatialReference()
            r.ImportFromEPSG(srs)
            d.SetProjection(r.ExportToWkt())
        return d

    def masked(gtype, co, nodata=None):
        def make(path):
            gdal.SetConfigOption("GDAL_TIFF_INTERNAL_MASK", "YES")
            d = create(path, gtype, co)
            b = d.GetRasterBand(1)
            b.WriteArray(base)
            if nodata is not None:
                b.SetNoDataValue(nodata)
            d.CreateMaskBand(gdal.GMF_PER_DATASET)
            b.GetMaskBand().WriteArray(hole)
            d = None
        return make

    def alpha(gtype, interleave):
        def make(path):
            d = create(path, gtype, ["PHOTOMETRIC=RGB", "ALPHA=YES", f"INTERLEAVE={interleave}",
                                     "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"], bands=4)
            for k in range(3):
                d.GetRasterBand(k + 1).WriteArray((base + 37 * k) % 250)
            d.GetRasterBand(4).WriteArray(np.where(hole == 0, 0, 255))
            d = None
        return make

    def sparse(gtype, co, nodata):
        def make(path):
            d = create(path, gtype, ["SPARSE_OK=TRUE"] + co)
            b = d.GetRasterBand(1)
            if nodata is not None:
                b.SetNoDataValue(nodata)
            b.WriteArray(base[:16, :16] + 1, 16, 0)  # one block (or strip part) written
            d = None
        return make

    def float16(co):
        def make(path):
            d = create(path, gdal.GDT_Float32, ["NBITS=16"] + co)
            d.GetRasterBand(1).WriteArray(base * 0.37 - 3.0)
            d.GetRasterBand(1).SetNoDataValue(-9999)
            d = None
        return make

    def georef(transform, srs, point):
        def make(path):
            d = create(path, gdal.GDT_Float32, [], srs=srs, transform=transform)
            if point:
                d.SetMetadataItem("AREA_OR_POINT", "Point")
            d.GetRasterBand(1).WriteArray(base)
            d = None
        return make

    def lerc(gtype, co, nodata=None, bands=1):
        def make(path):
            d = create(path, gtype, co, bands=bands)
            a = base % 250 if gtype in (gdal.GDT_Byte, gdal.GDT_Int16) else base * 0.731 - 5.0
            if nodata is not None:
                a = a.copy()
                a[3:9, 4:15] = nodata
                d.GetRasterBand(1).SetNoDataValue(nodata)
            for k in range(bands):
                d.GetRasterBand(k + 1).WriteArray(a + 3 * k)
            d = None
        return make

    tiled = ["TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"]
    yield "lerc_f32_tiled_nodata.tif", lerc(gdal.GDT_Float32, ["COMPRESS=LERC"] + tiled, nodata=-9999)
    yield "lerc_deflate_i16_strips.tif", lerc(gdal.GDT_Int16, ["COMPRESS=LERC_DEFLATE", "BLOCKYSIZE=5"])
    yield "lerc_zstd_f64_lossy_tiled.tif", lerc(gdal.GDT_Float64, ["COMPRESS=LERC_ZSTD", "MAX_Z_ERROR=0.01"] + tiled)
    yield "lerc_u8_3band_pixel_strips.tif", lerc(gdal.GDT_Byte, ["COMPRESS=LERC", "INTERLEAVE=PIXEL", "BLOCKYSIZE=8"], bands=3)
    yield "lerc_f32_3band_planar_tiled.tif", lerc(gdal.GDT_Float32, ["COMPRESS=LERC", "INTERLEAVE=BAND"] + tiled, bands=3)
    yield "mask_i16_tiled_deflate.tif", masked(gdal.GDT_Int16, tiled + ["COMPRESS=DEFLATE"])
    yield "mask_f32_strips.tif", masked(gdal.GDT_Float32, ["BLOCKYSIZE=5"])
    yield "mask_u8_strips_lzw_nodata.tif", masked(gdal.GDT_Byte, ["BLOCKYSIZE=7", "COMPRESS=LZW"], nodata=7)
    yield "mask_i32_tiled.tif", masked(gdal.GDT_Int32, tiled)
    yield "alpha_u8_pixel.tif", alpha(gdal.GDT_Byte, "PIXEL")
    yield "alpha_u8_band.tif", alpha(gdal.GDT_Byte, "BAND")
    yield "sparse_f32_tiled_deflate_nodata.tif", sparse(gdal.GDT_Float32, tiled + ["COMPRESS=DEFLATE"], -9999)
    yield "sparse_f32_strips.tif", sparse(gdal.GDT_Float32, ["BLOCKYSIZE=8"], None)
    yield "sparse_i16_tiled_lzw_nodata.tif", sparse(gdal.GDT_Int16, tiled + ["COMPRESS=LZW"], -32768)
    yield "float16_strips.tif", float16(["BLOCKYSIZE=5"])
    yield "float16_tiled_deflate_p3.tif", float16(tiled + ["COMPRESS=DEFLATE", "PREDICTOR=3"])
    def gcps(path):
        from osgeo import osr
        d = gdal.GetDriverByName("GTiff").Create(path, w, h, 1, gdal.GDT_Float32)
        d.GetRasterBand(1).WriteArray(base)
        r = osr.SpatialReference()
        r.ImportFromEPSG(4326)
        points = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
        d.SetGCPs([gdal.GCP(8.0 + 0.01 * x, 46.0 - 0.01 * y, 0, x, y) for x, y in points], r.ExportToWkt())
        d = None

    def rpc(path):
        d = create(path, gdal.GDT_Float32, [])
        d.GetRasterBand(1).WriteArray(base)
        one = " ".join(["1"] + ["0"] * 19)
        d.SetMetadata({"LINE_OFF": "14", "SAMP_OFF": "18", "LAT_OFF": "46", "LONG_OFF": "8", "HEIGHT_OFF": "0",
                       "LINE_SCALE": "14", "SAMP_SCALE": "18", "LAT_SCALE": "0.1", "LONG_SCALE": "0.1",
                       "HEIGHT_SCALE": "100", "LINE_NUM_COEFF": one, "LINE_DEN_COEFF": one,
                       "SAMP_NUM_COEFF": one, "SAMP_DEN_COEFF": one}, "RPC")
        d = None

    yield "georef_gcps.tif", gcps
    yield "georef_rpc.tif", rpc
    yield "georef_south_up.tif", georef([500000.0, 10.0, 0.0, 5200000.0, 0.0, 10.0], 32633, False)
    yield "georef_no_crs.tif", georef(gt, None, False)
    yield "georef_no_crs_point.tif", georef(gt, None, True)


def hand_tiff(entries, data):
    """A little-endian classic TIFF: `data` at offset 8, then one IFD of `entries`
    ((tag, type, count, value) with SHORT (3) or LONG (4) values held in the entry,
    ASCII (2) given as bytes)."""
    entries = sorted(entries, key=lambda e: e[0])
    ifd = 8 + len(data) + len(data) % 2
    out = b"II*\0" + struct.pack("<I", ifd) + data
    out = out.ljust(ifd, b"\0")
    extra_at = ifd + 2 + 12 * len(entries) + 4
    extra = b""
    out += struct.pack("<H", len(entries))
    for tag, ty, count, v in entries:
        out += struct.pack("<HHI", tag, ty, count)
        if ty == 2:
            if len(v) <= 4:
                out += v.ljust(4, b"\0")
            else:
                out += struct.pack("<I", extra_at + len(extra))
                extra += v
        elif ty == 3:
            out += struct.pack("<HH", v, 0)
        else:
            out += struct.pack("<I", v)
    return out + b"\0\0\0\0" + extra


def old_style_lzw(data):
    """LZW as TIFF writers did before TIFF 6.0 (and GIF does): codes packed least
    significant bit first, the code size growing once code 2^n has been assigned
    (the decoder runs one entry behind: no TIFF 6.0 early change); clear 256 first,
    end of information 257 last."""
    out, acc, nacc = bytearray(), 0, 0

    def put(code, bits):
        nonlocal acc, nacc
        acc |= code << nacc
        nacc += bits
        while nacc >= 8:
            out.append(acc & 255)
            acc >>= 8
            nacc -= 8

    table = {bytes([i]): i for i in range(256)}
    nxt, bits = 258, 9
    put(256, bits)
    w = b""
    for c in data:
        wc = w + bytes([c])
        if wc in table:
            w = wc
            continue
        put(table[w], bits)
        table[wc] = nxt
        nxt += 1
        if nxt == 4096:
            put(256, bits)
            table = {bytes([i]): i for i in range(256)}
            nxt, bits = 258, 9
        elif nxt > 1 << bits:
            bits += 1
        w = bytes([c])
    if w:
        put(table[w], bits)
    put(257, bits)
    if nacc:
        out.append(acc & 255)
    return bytes(out)


def hand_made_cases():
    """(file name, bytes) of TIFFs GDAL tolerates that no GDAL driver writes: no
    PhotometricInterpretation, no StripByteCounts (raw and DEFLATE), old-style LZW,
    MSVC's "1.#INF" nodata text."""
    w, h = 40, 30
    vals = np.array([(k % 97) * 13 - 400 for k in range(w * h)], dtype="<i2")
    raw = vals.tobytes()
    base = {256: (4, 1, w), 257: (4, 1, h), 258: (3, 1, 16), 259: (3, 1, 1), 262: (3, 1, 1),
            273: (4, 1, 8), 277: (3, 1, 1), 278: (4, 1, h), 279: (4, 1, len(raw)), 339: (3, 1, 2)}

    def build(changes, data, drop=()):
        e = dict(base)
        e.update(changes)
        return hand_tiff([(t, *v) for t, v in e.items() if t not in drop], data)

    import zlib
    lzw = old_style_lzw(raw)
    yield "hand_no_photometric.tif", build({}, raw, drop=(262,))
    yield "hand_no_byte_counts.tif", build({}, raw, drop=(279,))
    yield "hand_no_byte_counts_deflate.tif", build({259: (3, 1, 8)}, zlib.compress(raw), drop=(279,))
    yield "hand_old_style_lzw.tif", build({259: (3, 1, 5), 279: (4, 1, len(lzw))}, lzw)
    f32 = np.where(vals > 500, np.inf, vals).astype("<f4").tobytes()
    yield "hand_msvc_inf_nodata.tif", build({258: (3, 1, 32), 339: (3, 1, 3), 279: (4, 1, len(f32)),
                                             42113: (2, 7, b"1.#INF\0")}, f32)


def compare_cases():
    """Every case of case_variants(), built afresh: orogen's `info --json` (transform,
    EPSG, nodata) and its export (uncompressed, read back by GDAL) against GDAL's
    reading; where GDAL's mask is 0 orogen's cell must be nodata."""
    with tempfile.TemporaryDirectory() as tmp:
        for fname, data in hand_made_cases():
            path = os.path.join(tmp, fname)
            with open(path, "wb") as f:
                f.write(data)
            gdal.PushErrorHandler("CPLQuietErrorHandler")  # libtiff warns about each
            facts, arr = gdal_facts(path)
            gdal.PopErrorHandler()
            compare_read(path, facts, arr, tmp)
        for fname, make in case_variants():
            path = os.path.join(tmp, fname)
            make(path)
            facts, arr = gdal_facts(path)
            d = gdal.Open(path)
            band = d.GetRasterBand(1)
            flags = band.GetMaskFlags()
            masked = not (flags & gdal.GMF_ALL_VALID or flags & gdal.GMF_NODATA)
            if not masked:
                compare_read(path, facts, arr, tmp)
                continue
            mask = band.GetMaskBand().ReadAsArray()
            rc, out, err = orogen("export", path, "-o", os.path.join(tmp, "m.tif"), "--compress", "none")
            if rc != 0:
                check(False, f"{fname}: orogen export failed: {err.strip()}")
                continue
            o = gdal.Open(os.path.join(tmp, "m.tif"))
            ob = o.GetRasterBand(1)
            got = ob.ReadAsArray().astype(np.float64)
            nd = ob.GetNoDataValue()
            is_nd = np.isnan(got) if nd is None or nd != nd else (got == nd) | np.isnan(got)
            check(bool(is_nd[mask == 0].all()), f"{fname}: masked cells are not nodata")
            valid = (mask != 0) & ~is_nd
            check(bool((got[valid] == arr.astype(np.float64)[valid]).all()), f"{fname}: valid cells differ")
            check(list(o.GetGeoTransform()) == facts["transform"], f"{fname}: transform")
            o = None


def make_case_fixtures():
    out_dir = empty_fixture_dir("cases")
    manifest = {"files": []}
    for fname, make in case_variants():
        path = os.path.join(out_dir, fname)
        make(path)
        facts, arr = gdal_facts(path)
        ref = fname[:-4] + ".bin"
        np.ascontiguousarray(arr).astype(arr.dtype.newbyteorder("<")).tofile(os.path.join(out_dir, ref))
        d = gdal.Open(path)
        facts.update(file=fname, reference=ref, dtype=str(arr.dtype), bands=d.RasterCount,
                     tags=geotiff_tags(path))
        facts.update(mask_reference(d.GetRasterBand(1), out_dir, fname[:-4]))
        manifest["files"].append(facts)
    # Hand-made files no GDAL driver writes, GDAL's reading as the reference
    # (libtiff's warnings about the missing tags are expected).
    gdal.PushErrorHandler("CPLQuietErrorHandler")
    for fname, data in hand_made_cases():
        path = os.path.join(out_dir, fname)
        with open(path, "wb") as f:
            f.write(data)
        facts, arr = gdal_facts(path)
        ref = fname[:-4] + ".bin"
        np.ascontiguousarray(arr).astype(arr.dtype.newbyteorder("<")).tofile(os.path.join(out_dir, ref))
        facts.update(file=fname, reference=ref, dtype=str(arr.dtype), bands=1, tags={})
        manifest["files"].append(facts)
    gdal.PopErrorHandler()
    with open(os.path.join(out_dir, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    total = sum(os.path.getsize(os.path.join(out_dir, f)) for f in os.listdir(out_dir))
    print(f"wrote {len(manifest['files'])} cases, {total} bytes, to {out_dir}")


def scaled_variants():
    """(file name, band, writer) of tests/data/gdal/scaled: bands with GDAL's
    scale and offset (GDAL_METADATA), which a reader must apply."""
    w, h = 41, 23
    raw = (np.arange(w * h).reshape(h, w) * 37 % 9000).astype(np.float64) + 5000
    gt = [700000.0, 25.0, 0.0, 4100000.0, 0.0, -25.0]

    def make(gtype, co, scales, nodata=None):
        def write(path):
            from osgeo import osr
            d = gdal.GetDriverByName("GTiff").Create(path, w, h, len(scales), gtype, co)
            d.SetGeoTransform(gt)
            r = osr.SpatialReference()
            r.ImportFromEPSG(32633)
            d.SetProjection(r.ExportToWkt())
            for k, (scale, offset) in enumerate(scales):
                b = d.GetRasterBand(k + 1)
                a = raw.copy() + 11 * k
                if nodata is not None:
                    a[2:6, 3:9] = nodata
                    b.SetNoDataValue(nodata)
                b.WriteArray(a)
                if scale is not None:
                    b.SetScale(scale)
                if offset is not None:
                    b.SetOffset(offset)
            d = None
        return write

    tiled = ["TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16"]
    yield "u16_scale_offset_nodata.tif", 1, make(gdal.GDT_UInt16, tiled + ["COMPRESS=DEFLATE"], [(0.1, -500.0)], 65535)
    yield "i16_scale_only_strips.tif", 1, make(gdal.GDT_Int16, ["BLOCKYSIZE=5"], [(0.5, None)])
    yield "i32_offset_only.tif", 1, make(gdal.GDT_Int32, [], [(None, -1000.0)])
    yield "u16_2band_second.tif", 2, make(gdal.GDT_UInt16, ["INTERLEAVE=PIXEL"], [(0.25, 10.0), (0.02, -100.0)])


def make_scaled_fixtures():
    """Each scaled variant, and GDAL's unscaled reading of the band
    (`gdal_translate -unscale`, Float64, raw nodata cells as NaN) as the reference."""
    out_dir = empty_fixture_dir("scaled")
    manifest = {"files": []}
    for fname, band, make in scaled_variants():
        path = os.path.join(out_dir, fname)
        make(path)
        d = gdal.Open(path)
        b = d.GetRasterBand(band)
        raw = b.ReadAsArray()
        nd = b.GetNoDataValue()
        u = gdal.Translate("/vsimem/u.tif", path, bandList=[band], unscale=True, outputType=gdal.GDT_Float64)
        ref = u.GetRasterBand(1).ReadAsArray().astype(np.float64)
        u = None
        gdal.Unlink("/vsimem/u.tif")
        if nd is not None:
            ref[raw == nd] = np.nan
        name = fname[:-4] + f".b{band}.bin"
        ref.astype("<f8").tofile(os.path.join(out_dir, name))
        manifest["files"].append({"file": fname, "band": band, "reference": name,
                                  "width": d.RasterXSize, "height": d.RasterYSize,
                                  "scale": b.GetScale(), "offset": b.GetOffset(),
                                  "raw_dtype": str(raw.dtype), "raw_nodata": nd})
    with open(os.path.join(out_dir, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    print(f"wrote {len(manifest['files'])} scaled files to {out_dir}")


def make_fixtures():
    out_dir = os.path.join(ROOT, "tests", "data", "gdal")
    os.makedirs(out_dir, exist_ok=True)
    for f in os.listdir(out_dir):
        if f.endswith((".tif", ".bin", ".json")):
            os.remove(os.path.join(out_dir, f))
    manifest = {"files": []}

    def add(fname, ds, co, patch):
        path = os.path.join(out_dir, fname)
        gdal.Translate(path, ds, format="GTiff", creationOptions=co)
        if patch:
            patch_compression(path, patch)
        facts, arr = gdal_facts(path)
        ref = fname[:-4] + ".bin"
        np.ascontiguousarray(arr).astype(arr.dtype.newbyteorder("<")).tofile(os.path.join(out_dir, ref))
        facts.update(file=fname, reference=ref, dtype=str(arr.dtype))
        manifest["files"].append(facts)

    for dtype in SOURCES:
        src = source_dataset(dtype, find_window(dtype))
        for suffix, co in read_variants(dtype):
            add(f"{dtype}_{suffix}.tif", src, co, None)
    with tempfile.TemporaryDirectory() as tmp:
        for fname, ds, co, patch in extra_variants(tmp):
            add(fname, ds, co, patch)
        # A planar (band-interleaved) file for the hostile-input tests.
        d = gdal.GetDriverByName("MEM").Create("", 20, 10, 2, gdal.GDT_Int16)
        gdal.Translate(os.path.join(out_dir, "bad_planar.tif"), d, format="GTiff", creationOptions=["INTERLEAVE=BAND"])
    # Identical references are stored once.
    by_content = {}
    for e in manifest["files"]:
        p = os.path.join(out_dir, e["reference"])
        with open(p, "rb") as f:
            key = (e["dtype"], f.read())
        if key in by_content:
            os.remove(p)
            e["reference"] = by_content[key]
        else:
            by_content[key] = e["reference"]
    with open(os.path.join(out_dir, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    total = sum(os.path.getsize(os.path.join(out_dir, f)) for f in os.listdir(out_dir))
    print(f"wrote {len(manifest['files'])} fixtures, {total} bytes, to {out_dir}")


def compare_all():
    compare_cases()
    with tempfile.TemporaryDirectory() as tmp:
        # Reading: every variant, full size.
        for dtype in SOURCES:
            src = source_dataset(dtype)
            for suffix, co in read_variants(dtype):
                path = os.path.join(tmp, f"{dtype}_{suffix}.tif")
                co = [c.replace("BLOCKXSIZE=16", "BLOCKXSIZE=128").replace("BLOCKYSIZE=16", "BLOCKYSIZE=128").replace("BLOCKYSIZE=5", "BLOCKYSIZE=7") for c in co]
                gdal.Translate(path, src, format="GTiff", creationOptions=co)
                facts, arr = gdal_facts(path)
                compare_read(path, facts, arr, tmp)
                os.remove(path)
        for fname, ds, co, patch in extra_variants(tmp):
            path = os.path.join(tmp, fname)
            gdal.Translate(path, ds, format="GTiff", creationOptions=co)
            if patch:
                patch_compression(path, patch)
            facts, arr = gdal_facts(path)
            compare_read(path, facts, arr, tmp)
        # Writing: every compression x predictor, classic and BigTIFF, three types,
        # geographic + PixelIsPoint, projected, rotated.
        inputs = {}
        for dtype in SOURCES:
            p = os.path.join(tmp, f"src_{dtype}.tif")
            gdal.Translate(p, source_dataset(dtype), format="GTiff")
            inputs[dtype] = p
        inputs["rotated"] = os.path.join(tmp, "float32_rotated_deflate_p3.tif")
        inputs["projected_int16"] = os.path.join(DATA, "bigtujunga_srtm30m_utm11.tif")
        for name, src in inputs.items():
            facts, arr = gdal_facts(src)
            preds = ["1", "2", "3"] if arr.dtype.kind == "f" else ["1", "2"]
            for comp in ["none", "deflate", "lzw", "zstd"]:
                for pred in preds:
                    for big in ["no", "yes"]:
                        for block in (["256"] if name != "float32" else ["256", "48"]):
                            out = os.path.join(tmp, f"w_{name}_{comp}_{pred}_{big}_{block}.tif")
                            rc, _, err = orogen("export", src, "-o", out, "--compress", comp, "--predictor", pred,
                                                "--bigtiff", big, "--block", block)
                            what = os.path.basename(out)
                            if rc != 0:
                                check(False, f"{what}: orogen export failed: {err.strip()}")
                                continue
                            got_facts, got = gdal_facts(out)
                            check(got.dtype == arr.dtype and np.array_equal(got, arr, equal_nan=arr.dtype.kind == "f"), f"{what}: GDAL reads other values")
                            for k in ["width", "height", "transform", "epsg", "raster_type"]:
                                check(got_facts[k] == facts[k], f"{what}: {k} {got_facts[k]} != {facts[k]}")
                            check(same_nodata(got_facts["nodata"], facts["nodata"]), f"{what}: nodata {got_facts['nodata']} != {facts['nodata']}")
                            with open(out, "rb") as f:
                                magic = f.read(4)
                            check(magic == (b"II+\0" if big == "yes" else b"II*\0"), f"{what}: BigTIFF flag")
                            os.remove(out)


if __name__ == "__main__":
    if "--fixtures" in sys.argv[1:]:
        make_fixtures()
    elif "--band-fixtures" in sys.argv[1:]:
        make_band_fixtures()
    elif "--case-fixtures" in sys.argv[1:]:
        make_case_fixtures()
    elif "--scaled-fixtures" in sys.argv[1:]:
        make_scaled_fixtures()
    elif "--cases" in sys.argv[1:]:
        compare_cases()
        print(f"{passed} passed, {failed} failed")
        sys.exit(1 if failed else 0)
    else:
        compare_all()
        print(f"{passed} passed, {failed} failed")
        sys.exit(1 if failed else 0)
