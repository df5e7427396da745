"""The operations beyond the core hydrology and descriptors (erosion,
basins, streams, indices, viewshed, tiles, synthesis, jobs) against the CLI
on the same input and against oracles written here; progress callbacks,
cancellation and in-place array reads."""

import json
import math
import subprocess

import numpy as np
import pytest

import orogen
from conftest import ROOT, write_asc
from test_io import CELL, TRANSFORM, run_cli, same


def cone(n=33, top=300.0, fall=10.0):
    y, x = np.mgrid[0:n, 0:n]
    c = n // 2
    return (top - fall * np.hypot(x - c, y - c)).astype(np.float32)


def test_erode_diffusion_is_the_explicit_scheme():
    """Hillslope diffusion dz/dt = D lap z, one explicit step on unit cells:
    z' = z + D dt (z_E + z_W + z_N + z_S - 4 z) in the interior (written
    here), the volume conserved; the edge is the model's own business."""
    z = cone()
    d, dt = 0.1, 1.0
    out = orogen.erode(z, "diffusion", 1, diffusivity=d, dt=dt, transform=(0, 1, 0, 0, 0, -1))
    zz = z.astype(np.float64)
    lap = zz[1:-1, 2:] + zz[1:-1, :-2] + zz[2:, 1:-1] + zz[:-2, 1:-1] - 4 * zz[1:-1, 1:-1]
    want = zz[1:-1, 1:-1] + d * dt * lap
    np.testing.assert_allclose(out[2:-2, 2:-2], want[1:-1, 1:-1], rtol=0, atol=1e-3)
    assert out[16, 16] < z[16, 16]  # the summit is worn down
    # zero-flux edges: what leaves one cell enters another
    assert abs(out.astype(np.float64).sum() - zz.sum()) < 1e-2


@pytest.mark.parametrize("model,flags,kwargs", [
    ("thermal", ["--steps", "15", "--talus", "30"], {"steps": 15, "talus": 30.0}),
    ("hydraulic", ["--steps", "12", "--seed", "5", "--set", "rain=0.02"], {"steps": 12, "seed": 5,
                                                                           "set": {"rain": 0.02}}),
    ("stream-power", ["--steps", "5", "--uplift", "0.001", "--dt", "1000"], {"steps": 5, "uplift": 0.001,
                                                                             "dt": 1000.0}),
])
def test_erode_identical_to_cli(cli, tmp_path, rough_dem, model, flags, kwargs):
    path = write_asc(tmp_path / "dem.asc", rough_dem, cell=CELL, x0=500000.0,
                     y0=4100000.0 - CELL * rough_dem.shape[0])
    out = tmp_path / "eroded.tif"
    run_cli(cli, "erode", path, "--model", model, "-o", out, *flags)
    want = orogen.open(out).read()
    steps = kwargs.pop("steps")
    same(orogen.erode(path, model, steps, **kwargs), want)
    same(orogen.erode(rough_dem, model, steps, transform=TRANSFORM, crs=32633, **kwargs), want)


def test_erode_hydraulic_extras_are_the_clis(cli, tmp_path, rough_dem):
    path = write_asc(tmp_path / "dem.asc", rough_dem, cell=CELL)
    run_cli(cli, "erode", path, "--model", "hydraulic", "--steps", "10", "--water", tmp_path / "w.tif",
            "--sediment", tmp_path / "s.tif", "-o", tmp_path / "e.tif")
    res = orogen.erode(path, "hydraulic", 10, water=True, sediment=True)
    assert set(res) == {"elevation", "water", "sediment"}
    same(res["elevation"], orogen.open(tmp_path / "e.tif").read())
    same(res["water"], orogen.open(tmp_path / "w.tif").read())
    same(res["sediment"], orogen.open(tmp_path / "s.tif").read())
    assert np.nanmin(res["water"]) >= 0 and np.nanmax(res["water"]) > 0


def test_erode_refuses_bad_parameters_before_reading():
    with pytest.raises(orogen.InvalidInputError, match="steps"):
        orogen.erode(cone(), "thermal")
    with pytest.raises(orogen.InvalidInputError, match="rainfall|unknown|valid"):
        orogen.erode(cone(), "hydraulic", 3, set={"rainfall": 1})


def test_basins_label_outlets_by_hand():
    d8 = np.full((4, 5), 1, dtype=np.uint8)  # every cell flows east ...
    d8[:, 4] = 0  # ... to an outlet in the last column
    d8[3, :] = 4  # the last row flows south, off the grid
    b = orogen.basins(d8)
    assert b.dtype == np.uint32
    rows = [set(b[r].tolist()) for r in range(3)]
    assert all(len(s) == 1 for s in rows)  # one basin per row
    assert len({next(iter(s)) for s in rows}) == 3
    assert len(set(b[3].tolist())) == 5  # each cell of the last row leaves the grid alone


def test_basins_streams_hydro_index_identical_to_cli(cli, tmp_path, rough_dem):
    path = write_asc(tmp_path / "dem.asc", rough_dem, cell=CELL)
    filled, d8, acc = tmp_path / "f.tif", tmp_path / "d8.tif", tmp_path / "acc.tif"
    run_cli(cli, "fill", path, "-o", filled)
    run_cli(cli, "flow", filled, "-o", d8)
    run_cli(cli, "accumulate", d8, "-o", acc)
    run_cli(cli, "basins", d8, "-o", tmp_path / "b.tif")
    same(orogen.basins(d8), orogen.open(tmp_path / "b.tif").read())
    same(orogen.basins(orogen.open(d8).read()), orogen.open(tmp_path / "b.tif").read())
    run_cli(cli, "hydro-index", "--index", "twi", "--dem", filled, "--acc", acc, "-o", tmp_path / "twi.tif")
    same(orogen.hydro_index("twi", dem=filled, acc=acc), orogen.open(tmp_path / "twi.tif").read())
    # arrays for the rasters: the same result
    same(orogen.hydro_index("twi", dem=orogen.open(filled).read(), acc=orogen.open(acc).read(),
                            transform=(0, CELL, 0, 0, 0, -CELL)),
         orogen.open(tmp_path / "twi.tif").read())
    run_cli(cli, "streams", d8, "--threshold", "50", "-o", tmp_path / "cli.geojson")
    wrote = orogen.streams(d8, output=tmp_path / "py.geojson", threshold=50)
    assert wrote == [str(tmp_path / "py.geojson")]
    a = json.loads((tmp_path / "cli.geojson").read_text())
    b = json.loads((tmp_path / "py.geojson").read_text())
    assert a == b and len(a["features"]) > 0


def test_viewshed_over_a_ridge_by_hand():
    """An observer on flat ground before a wall: cells behind the wall and
    lower than the sight line over its top are hidden (checked here with
    the line of sight written out)."""
    z = np.zeros((1, 40), dtype=np.float32) + np.zeros((9, 1), dtype=np.float32)
    z[:, 10] = 20.0  # a wall 20 m high at column 10
    v = orogen.viewshed(z, at="2,4", pixel=True, observer_height=1.7, transform=(0, 1, 0, 0, 0, -1))
    assert v.dtype == np.uint8
    row = v[4]
    assert row[2] == 1 and row[10] == 1  # the observer's cell and the wall top
    # Behind the wall the ground (0 m) is below the sight line over the wall
    # top for every column: hidden.
    for c in range(11, 40):
        sight = 1.7 + (20.0 - 1.7) * (c - 2) / (10 - 2)
        assert sight > 0 and row[c] == 0, c


def test_info_reports_the_array():
    d = orogen.info(np.arange(12, dtype=np.int16).reshape(3, 4), stats=True, transform=TRANSFORM, crs=32633)
    assert (d["width"], d["height"], d["dtype"]) == (4, 3, "i16")
    assert d["epsg"] == 32633 and d["stats"]["min"] == 0 and d["stats"]["max"] == 11
    assert d["path"] == "<array>"


def test_tiles_pmtiles_and_render_png(tmp_path):
    z = orogen.synth.noise(128, seed=4, amplitude=900.0, cell=30.0)
    t = (600000.0, 30.0, 0.0, 5100000.0, 0.0, -30.0)
    wrote = orogen.tiles(z, output=tmp_path / "dem.pmtiles", transform=t, crs=32632)
    assert any(p.endswith("dem.pmtiles") for p in wrote)
    data = (tmp_path / "dem.pmtiles").read_bytes()
    assert data[:7] == b"PMTiles" and data[7] == 3
    orogen.render(z, output=tmp_path / "r.png", transform=t, crs=32632)
    png = (tmp_path / "r.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (w, h) == (128, 128)


def test_synth_methods_are_the_clis_bytes(cli, tmp_path):
    m = ROOT / "configs" / "tectonic-map.geojson"
    run_cli(cli, "synth", "tectonic", "--map", m, "--cell", "300", "-o", tmp_path / "t.tif")
    same(orogen.synth.tectonic(m, cell=300.0), orogen.open(tmp_path / "t.tif").read())
    run_cli(cli, "synth", "rivers", "--size", "64", "--seed", "3", "-o", tmp_path / "r.tif")
    same(orogen.synth.rivers(size="64", seed=3), orogen.open(tmp_path / "r.tif").read())


def test_run_command_and_job(tmp_path):
    z = orogen.synth.noise(48, seed=1, amplitude=300.0)
    orogen.export(z, tmp_path / "dem.tif", transform=TRANSFORM, crs=32633)
    job = tmp_path / "job.toml"
    job.write_text(
        '[inputs]\ndem = "dem.tif"\n'
        '[[step]]\nname = "filled"\nrun = "fill"\ninput = "dem"\noutput = "filled.tif"\n'
        '[[step]]\nname = "slope"\nrun = "slope"\ninput = "filled"\noutput = "slope.tif"\n'
    )
    plan = orogen.run_job(job, dry_run=True)
    assert len(plan) == 2 and "fill" in plan[0]
    orogen.run_job(job)
    same(orogen.open(tmp_path / "filled.tif").read(), orogen.fill(z))
    with pytest.raises(orogen.InvalidInputError, match="no option --colour"):
        orogen.run_command("slope", [z], tmp_path / "x.tif", colour=1)
    with pytest.raises(orogen.InvalidInputError, match="view"):
        orogen.run_command("view", [tmp_path / "dem.tif"])


def test_progress_callback_cancel_and_its_exception():
    z = orogen.synth.noise(200, seed=2, amplitude=500.0)
    calls = []
    orogen.slope(z, tile=50, progress=lambda step, done, total: calls.append((step, done, total)))
    assert calls == [("slope", k, 16) for k in range(1, 17)]
    with pytest.raises(orogen.OrogenError, match="cancelled"):
        orogen.slope(z, tile=50, progress=lambda *a: False)

    class Stop(Exception):
        pass

    def boom(step, done, total):
        if done == 3:
            raise Stop("enough")
        return True

    with pytest.raises(Stop, match="enough"):
        orogen.fill(z, tile=50, memory="16MiB", progress=boom)
    # progress through a command run too
    seen = []
    orogen.basins(orogen.flow(orogen.fill(z)), tile=50, progress=lambda *a: seen.append(a))
    assert seen and all(d <= t for _, d, t in seen)


def test_progress_true_draws_tqdm_or_says_what_is_missing():
    z = orogen.synth.noise(64, seed=2)
    try:
        import tqdm  # noqa: F401
    except ImportError:
        with pytest.raises(orogen.InvalidInputError, match="tqdm"):
            orogen.slope(z, progress=True)
        return
    same(orogen.slope(z, progress=True), orogen.slope(z))


def test_arrays_are_read_in_place_and_left_unchanged():
    """A native, C-contiguous array is borrowed (numpy's borrow flag is
    taken while the run lasts: a concurrent writer would be refused) and
    never written; a non-contiguous view is copied by the Python layer."""
    z = orogen.synth.noise(64, seed=9, amplitude=100.0)
    before = z.copy()
    out = orogen.fill(z)
    assert np.array_equal(z, before) and out is not z
    view = z[::2, ::2]
    same(orogen.fill(view), orogen.fill(np.ascontiguousarray(view)))


def cli_files(binary, *args):
    """Run a command that writes files (no `-q`: not every one takes it)."""
    p = subprocess.run([binary, *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def same_files(a, b):
    """Two folders (or files) hold the same bytes, file by file."""
    if a.is_dir():
        names = sorted(p.name for p in a.iterdir())
        assert names == sorted(p.name for p in b.iterdir()) and names
        for n in names:
            same_files(a / n, b / n)
    else:
        assert a.read_bytes() == b.read_bytes(), a.name


ALPS = ROOT / "tests" / "data" / "oro" / "srtm3_N46E008_crop.tif"


def test_orometric_analysis_commands_are_the_clis_files(cli, tmp_path):
    """ridges, orostats, compare and ingest write what the CLI writes."""
    cli_files(cli, "ridges", ALPS, "-o", tmp_path / "cli_ridges")
    wrote = orogen.ridges(ALPS, output=tmp_path / "py_ridges")
    assert any(p.endswith("ridges.geojson") for p in wrote)
    same_files(tmp_path / "cli_ridges", tmp_path / "py_ridges")
    # the array in memory with its georeferencing: the same ridges (the
    # file's PixelIsPoint tag is not carried by a numpy array, so the
    # rasters are compared cell by cell, the GeoJSON byte by byte)
    r = orogen.open(ALPS)
    orogen.ridges(r.read(), output=tmp_path / "arr_ridges", transform=r.transform, crs=r.crs, nodata=r.nodata)
    for name in ("ppa_ridges.tif", "ridge_levels.tif", "ridge_orders.tif"):
        same(orogen.open(tmp_path / "arr_ridges" / name).read(), orogen.open(tmp_path / "cli_ridges" / name).read())
    same_files(tmp_path / "cli_ridges" / "ridges.geojson", tmp_path / "arr_ridges" / "ridges.geojson")

    cli_files(cli, "orostats", ALPS, "--radius", "3000", "-o", tmp_path / "cli.json")
    orogen.orostats(ALPS, radius="3000", output=tmp_path / "py.json")
    same_files(tmp_path / "cli.json", tmp_path / "py.json")
    assert len(json.loads((tmp_path / "py.json").read_text())["disks"]) > 10

    smooth = orogen.erode(ALPS, "diffusion", 20, diffusivity=2000.0, dt=1.0)
    orogen.export(smooth, tmp_path / "smooth.tif", transform=r.transform, crs=r.crs)
    cli_files(cli, "compare", tmp_path / "smooth.tif", ALPS, "-o", tmp_path / "cli_cmp")
    rep = orogen.compare(tmp_path / "smooth.tif", ALPS, output=tmp_path / "py_cmp")
    assert rep == json.loads((tmp_path / "cli_cmp" / "compare.json").read_text())
    # a smoothed terrain has fewer peaks than the real one: the report says
    # the two differ, and a terrain against itself differs by nothing
    self_rep = orogen.compare(ALPS, ALPS, output=tmp_path / "self_cmp")
    assert json.dumps(rep) != json.dumps(self_rep)

    store = orogen.ingest(ALPS, output=tmp_path / "alps.tiles", store_tile=128)
    same(store.read(), r.read())


def test_orometric_synthesis_chain_is_the_clis_files(cli, tmp_path):
    """profile -> divide tree -> terrain from the tree; orometric terrain
    from the profile; patch-based optimisation: each the CLI's bytes."""
    cli_files(cli, "synth", "profile", ALPS, "--min-prominence", "30", "-o", tmp_path / "cli_p.json")
    orogen.synth.profile(ALPS, min_prominence=30.0, output=tmp_path / "p.json")
    same_files(tmp_path / "cli_p.json", tmp_path / "p.json")
    p = tmp_path / "p.json"

    cli_files(cli, "synth", "divide-tree", "--profile", p, "--size", "120x100", "--cell", "90", "-o",
              tmp_path / "cli_tree.json")
    orogen.synth.divide_tree(p, size="120x100", cell=90.0, output=tmp_path / "tree.json")
    same_files(tmp_path / "cli_tree.json", tmp_path / "tree.json")

    cli_files(cli, "synth", "from-tree", tmp_path / "tree.json", "-o", tmp_path / "ft.tif")
    ft = orogen.synth.from_tree(tmp_path / "tree.json")
    same(ft, orogen.open(tmp_path / "ft.tif").read())
    assert ft.shape == (100, 120) and np.nanmax(ft) > np.nanmin(ft)

    cli_files(cli, "synth", "orometric", "--profile", p, "--size", "120x100", "--cell", "90", "-o",
              tmp_path / "o.tif")
    o = orogen.synth.orometric(p, size="120x100", cell=90.0)
    same(o, orogen.open(tmp_path / "o.tif").read())

    cli_files(cli, "synth", "optimise", "--source", ALPS, "--guide", tmp_path / "o.tif", "--size", "120x100",
              "-o", tmp_path / "opt.tif")
    opt = orogen.synth.optimise(ALPS, tmp_path / "o.tif", size="120x100")
    same(opt, orogen.open(tmp_path / "opt.tif").read())


def test_fill_nodata_is_the_clis_and_idw_by_hand(cli, tmp_path):
    """Two void cells in a row of a 1-row raster (no valid cell on the
    other rays): the first has 10 one cell west and 30 two cells east,
    Shepard's weights 1/d^2 give (10/1 + 30/4) / (1 + 1/4) = 14; the second
    (10 two cells west, 30 one east) 26."""
    z = np.array([[7.0, 10.0, np.nan, 50.0, 30.0]], dtype=np.float32)
    z[0, 3] = np.nan
    out = orogen.fill_nodata(z, transform=(0, 1, 0, 0, 0, -1))
    assert out[0, 0] == 7.0 and out[0, 1] == 10.0 and out[0, 4] == 30.0
    assert out[0, 2] == pytest.approx(14.0, rel=1e-6) and out[0, 3] == pytest.approx(26.0, rel=1e-6)
    # the CLI on a real crop with voids: the same bytes, tiled in Python
    run_cli(cli, "fill-nodata", ALPS, "--max-distance", "20", "-o", tmp_path / "f.tif")
    same(orogen.fill_nodata(ALPS, max_distance="20", tile=37), orogen.open(tmp_path / "f.tif").read())


def test_sea_level_and_nodata_are_the_clis(cli, tmp_path):
    """``sea_level=``, ``mask=`` and ``nodata=`` read an input as the CLI's
    --sea-level, --mask and --nodata do, for a path and for an array: on SRTM3 N43E007 (the
    Mediterranean at 0 m) every cell at or below the level is nodata in the
    output, and the bytes are the CLI's."""
    hgt = ROOT / "tests" / "data" / "srtm" / "N43E007.hgt"
    out = tmp_path / "cli.tif"
    run_cli(cli, "fill", hgt, "--sea-level", "0", "-o", out)
    want = orogen.open(out).read()
    z = orogen.open(hgt).read()
    assert (z <= 0).mean() > 0.5
    nd = orogen.open(out).nodata
    sea = want[z <= 0]
    assert (np.isnan(sea) if want.dtype.kind == "f" else sea == nd).all()
    same(orogen.fill(hgt, sea_level=0), want)
    # an array: int16 with SRTM's nodata, the same rule
    r = orogen.open(hgt)
    same(orogen.fill(z, transform=r.transform, crs=r.crs, nodata=-32768, sea_level=0), want)
    # mask=: a raster on the grid, nodata on the sea (the CLI's own output), as --mask
    same(orogen.fill(hgt, mask=out), want)
    same(orogen.fill(z, transform=r.transform, crs=r.crs, nodata=-32768, mask=orogen.open(out)), want)
    # --nodata on a path: the cells at exactly 0 m become nodata, as the CLI's
    out0 = tmp_path / "cli0.tif"
    run_cli(cli, "slope", hgt, "--nodata", "0", "-o", out0)
    same(orogen.slope(hgt, nodata=0), orogen.open(out0).read())
    # an integer array without nodata cannot take a sea level
    with pytest.raises(orogen.InvalidInputError, match="--nodata"):
        orogen.fill(z.astype(np.int16), transform=r.transform, crs=r.crs, sea_level=0)


def test_sinks_and_sparse_mosaics_are_the_clis(cli, tmp_path):
    """``sinks=`` of :func:`orogen.fill` and :func:`orogen.flow` give the
    CLI's bytes (the deepest depression of the Big Tujunga crop declared a
    sink stays unfilled); a sparse VRT mosaic is refused unless
    ``allow_sparse=True``, as the CLI's --allow-sparse."""
    dem = ROOT / "tests" / "data" / "bigtujunga_crop.tif"
    plain = orogen.fill(dem)
    z = orogen.open(dem).read().astype(np.float64)
    deepest = np.unravel_index(np.nanargmax(plain - z), z.shape)
    assert plain[deepest] - z[deepest] > 1.0
    t = orogen.open(dem).transform  # GDAL order: x0, dx, 0, y0, 0, dy
    x = t[0] + (deepest[1] + 0.5) * t[1]
    y = t[3] + (deepest[0] + 0.5) * t[5]
    sinks = tmp_path / "sinks.csv"
    sinks.write_text(f"x,y\n{x},{y}\n")
    out = tmp_path / "cli.tif"
    run_cli(cli, "fill", dem, "--sinks", sinks, "-o", out)
    got = orogen.fill(dem, sinks=sinks)
    same(got, orogen.open(out).read())
    assert got[deepest] == z[deepest]
    d8 = tmp_path / "d8.tif"
    run_cli(cli, "flow", out, "--sinks", sinks, "-o", d8)
    flow = orogen.flow(out, sinks=sinks)
    same(flow, orogen.open(d8).read())
    assert flow[deepest] == 0
    sparse = ROOT / "tests" / "data" / "vrt" / "sparse.vrt"
    with pytest.raises(orogen.InvalidInputError, match="allow-sparse"):
        orogen.slope(sparse)
    sp = tmp_path / "sp.tif"
    run_cli(cli, "slope", sparse, "--allow-sparse", "-o", sp)
    same(orogen.slope(sparse, allow_sparse=True), orogen.open(sp).read())
