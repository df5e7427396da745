"""Files, the CLI, xarray and errors: results identical to the ``orogen``
binary on the same input, a path run out of core equal to the in-memory
call, xarray round trips keeping coordinates, CRS and nodata, and library
errors as ``OrogenError`` subclasses."""

import subprocess

import numpy as np
import pytest

import orogen
from conftest import write_asc

CELL = 25.0
TRANSFORM = (500000.0, CELL, 0.0, 4100000.0, 0.0, -CELL)


def run_cli(binary, *args):
    p = subprocess.run([binary, *map(str, args), "-q"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def same(a, b):
    """Equal arrays, bytes and NaN positions included."""
    assert a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b)) if a.dtype.kind == "f" else True
    assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    if a.dtype.kind == "f":
        assert np.nan_to_num(a, nan=-1e30).tobytes() == np.nan_to_num(b, nan=-1e30).tobytes()


@pytest.fixture
def dem_asc(tmp_path, rough_dem):
    z = rough_dem.copy()
    z[5:8, 10:13] = np.nan  # a nodata hole
    return write_asc(tmp_path / "dem.asc", z, cell=CELL, x0=500000.0, y0=4100000.0 - CELL * z.shape[0]), z


CASES = [
    ("fill", [], {}),
    ("fill-epsilon", [], {}),
    ("breach", [], {}),
    ("breach", ["--method", "least-cost", "--dist", "8"], {"method": "least-cost", "dist": 8}),
    ("flow", [], {}),
    ("slope", ["--units", "percent"], {"units": "percent"}),
    ("aspect", ["--compute-edges"], {"compute_edges": True}),
    ("hillshade", ["--azimuth", "200", "--altitude", "30"], {"azimuth": 200.0, "altitude": 30.0}),
]


@pytest.mark.parametrize("cmd,flags,kwargs", CASES, ids=[c[0] + str(i) for i, c in enumerate(CASES)])
def test_identical_to_cli(cli, tmp_path, dem_asc, cmd, flags, kwargs):
    path, z = dem_asc
    out = tmp_path / f"{cmd}.tif"
    run_cli(cli, cmd, path, "-o", out, *flags)
    want = orogen.open(out).read()
    fn = getattr(orogen, cmd.replace("-", "_"))
    same(fn(path, **kwargs), want)  # the file as input, result in memory
    same(fn(z, transform=TRANSFORM, crs=32633, **kwargs), want)  # the array as input


def test_accumulate_and_watersheds_identical_to_cli(cli, tmp_path, dem_asc):
    path, z = dem_asc
    d8 = tmp_path / "d8.tif"
    run_cli(cli, "flow", path, "-o", d8)
    for cmd in ("accumulate", "watersheds"):
        out = tmp_path / f"{cmd}.tif"
        run_cli(cli, cmd, d8, "-o", out)
        same(getattr(orogen, cmd)(d8), orogen.open(out).read())
        same(getattr(orogen, cmd)(orogen.open(d8).read()), orogen.open(out).read())
    out = tmp_path / "dinf.tif"
    run_cli(cli, "accumulate", path, "--method", "dinf", "-o", out)
    same(orogen.accumulate(path, method="dinf"), orogen.open(out).read())


def test_metrics_identical_to_cli(cli, tmp_path, dem_asc):
    path, _ = dem_asc
    folder = tmp_path / "m"
    run_cli(cli, "metric", path, "-m", "tpi:radius=2c,slope,tri", "-o", folder)
    got = orogen.metrics(path, "tpi:radius=2c,slope,tri")
    assert len(got) == 3
    for name, arr in got.items():
        same(arr, orogen.open(folder / f"{name}.tif").read())


def test_peaks_identical_to_cli(cli, tmp_path, dem_asc):
    path, _ = dem_asc
    folder = tmp_path / "p"
    run_cli(cli, "peaks", path, "--min-prominence", "5", "-o", folder)
    table = orogen.peaks(path, min_prominence=5)
    lines = (folder / "peaks.csv").read_text().splitlines()
    assert list(table) == lines[0].split(",")
    assert len(table["elevation"]) == len(lines) - 1 > 0
    for k, line in enumerate(lines[1:]):
        for name, cell in zip(table, line.split(",")):
            v = table[name][k]
            if cell == "":
                assert v == -1 or np.isnan(v)
            else:
                assert v == float(cell)
    # written by the package: the same files as the CLI's
    files = orogen.peaks(path, min_prominence=5, output=tmp_path / "p2")
    assert sorted(p.split("/")[-1] for p in map(str, files)) == sorted(x.name for x in folder.iterdir())
    assert (tmp_path / "p2" / "peaks.csv").read_bytes() == (folder / "peaks.csv").read_bytes()


def test_out_of_core_path_run_equals_in_memory(tmp_path, dem_asc):
    path, z = dem_asc
    mem = orogen.fill(z, transform=TRANSFORM, crs=32633)
    store = tmp_path / "filled.tiles"
    h = orogen.fill(path, output=store, memory="64MiB", tile=16)
    assert isinstance(h, orogen.Raster)
    assert h.shape == z.shape and h.dtype == np.float32
    assert h.crs is None  # an ESRI ASCII grid has no CRS
    assert h.transform == pytest.approx(TRANSFORM)
    same(h.read(), mem)
    # windows, and past the edge (nodata)
    same(h.read((3, 4, 10, 7)), mem[4:11, 3:13])
    part = h.read((45, 35, 10, 10))
    same(part[:5, :5], mem[35:40, 45:50])
    assert np.isnan(part[5:, :]).all() and np.isnan(part[:, 5:]).all()
    # a chain of file runs equals the chain in memory
    d8 = orogen.flow(h, output=tmp_path / "d8.tif", tile=16)
    acc = orogen.accumulate(d8, output=tmp_path / "acc.tiles", tile=16, format={"store_tile": 16})
    same(acc.read(), orogen.accumulate(orogen.flow(mem)))
    ms = orogen.metrics(path, ["tpi:radius=2c"], output=tmp_path / "metrics", tile=16)
    (name, r), = ms.items()
    same(r.read(), orogen.metrics(z, ["tpi:radius=2c"], transform=TRANSFORM, crs=32633)[name])


def test_geotiff_output_and_format_settings(tmp_path, rough_dem):
    r = orogen.slope(rough_dem, output=tmp_path / "s.tif", format={"compress": "zstd", "block": 16})
    same(r.read(), orogen.slope(rough_dem))
    assert r.nodata is not None


def test_xarray_round_trip_keeps_coords_crs_nodata(rough_dem):
    xr = pytest.importorskip("xarray")
    z = rough_dem.copy()
    z[0:3, 0:3] = -9999.0
    ys = 4100000.0 - CELL * (np.arange(z.shape[0]) + 0.5)
    xs = 500000.0 + CELL * (np.arange(z.shape[1]) + 0.5)
    da = xr.DataArray(z, dims=("y", "x"), coords={"y": ys, "x": xs}, attrs={"units": "m", "nodata": -9999.0})
    try:
        import rioxarray  # noqa: F401

        da = da.rio.write_crs("EPSG:32633").rio.write_nodata(-9999.0, encoded=False)
        rio = True
    except ImportError:
        da.attrs["crs"] = "EPSG:32633"
        rio = False
    out = orogen.fill(da)
    assert isinstance(out, xr.DataArray)
    assert out.dims == da.dims
    np.testing.assert_array_equal(out["x"], xs)
    np.testing.assert_array_equal(out["y"], ys)
    assert out.attrs["units"] == "m"
    assert np.isnan(out.values[0:3, 0:3]).all()
    want = orogen.fill(np.where(z == -9999.0, np.nan, z).astype(np.float32), transform=TRANSFORM, crs=32633)
    same(out.values, want)
    if rio:
        assert out.rio.crs.to_epsg() == 32633
        assert np.isnan(out.rio.nodata)
        assert out.rio.transform().to_gdal() == pytest.approx(TRANSFORM)
    else:
        assert out.attrs["crs"] == "EPSG:32633"
    # the transform came from the coordinates: slope uses the 25 m cells
    s = orogen.slope(da)
    same(s.values, orogen.slope(np.where(z == -9999.0, np.nan, z).astype(np.float32), transform=TRANSFORM, crs=32633))


def test_raster_to_xarray(tmp_path, rough_dem):
    pytest.importorskip("xarray")
    r = orogen.fill(rough_dem, transform=TRANSFORM, crs=32633, output=tmp_path / "f.tif")
    assert r.crs == 32633 and r.transform == pytest.approx(TRANSFORM)
    da = r.to_xarray()
    assert da.shape == rough_dem.shape
    assert da["x"].values[0] == pytest.approx(500000.0 + CELL / 2)
    assert da["y"].values[0] == pytest.approx(4100000.0 - CELL / 2)
    same(da.values, r.read())
    back = orogen.fill(da)  # a DataArray from a file goes back in
    same(back.values, r.read())


def test_affine_transform_accepted(rough_dem):
    affine = pytest.importorskip("affine")
    t = affine.Affine(CELL, 0.0, 500000.0, 0.0, -CELL, 4100000.0)
    same(orogen.slope(rough_dem, transform=t, crs="EPSG:32633"), orogen.slope(rough_dem, transform=TRANSFORM, crs=32633))


def test_errors_are_orogen_errors(tmp_path, rough_dem):
    with pytest.raises(orogen.StorageError) as e:
        orogen.fill(tmp_path / "missing.tif")
    assert isinstance(e.value, orogen.OrogenError) and "missing.tif" in str(e.value)
    with pytest.raises(orogen.InvalidInputError, match="max-depth"):
        orogen.breach(rough_dem, method="hybrid")
    with pytest.raises(orogen.InvalidInputError, match="radians"):
        orogen.slope(rough_dem, units="radians")
    with pytest.raises(orogen.InvalidInputError, match="too small"):
        orogen.breach(rough_dem, memory="1KiB")
    with pytest.raises(orogen.MemoryBudgetError, match="raise --memory"):
        orogen.breach(rough_dem, method="least-cost", dist=3000, memory="16MiB")
    bad = tmp_path / "bad.tif"
    bad.write_bytes(b"this is not a raster at all")
    with pytest.raises(orogen.CorruptInputError, match="not a TIFF"):
        orogen.open(bad)
    (tmp_path / "bad.xyz").write_bytes(b"neither")
    with pytest.raises(orogen.UnsupportedFormatError, match="unknown raster format"):
        orogen.slope(tmp_path / "bad.xyz")
    with pytest.raises(orogen.InvalidInputError):
        orogen.fill(np.zeros((2, 3, 4), dtype=np.float32))
    with pytest.raises(orogen.InvalidInputError, match="metric"):
        orogen.metrics(rough_dem, ["no-such-metric"])
    # the interpreter is still alive and the package still works
    assert orogen.fill(rough_dem).shape == rough_dem.shape


def test_defaults_are_the_clis():
    assert orogen.defaults("slope") == {"units": "degrees", "z_factor": 1.0, "compute_edges": False}
    assert orogen.defaults("peaks")["min_prominence"] == 30.0
    assert orogen.defaults("run")["memory"] == "1GiB"
