"""Every function on small DEMs against oracles written here in numpy (no
code shared with orogen): a brute-force fill, D8 codes by hand, Horn's
gradient in closed form, window statistics, a flood-fill prominence."""

import math
import subprocess

import numpy as np
import pytest

import orogen

# (dy, dx) of the ESRI D8 codes.
D8 = {1: (0, 1), 2: (1, 1), 4: (1, 0), 8: (1, -1), 16: (0, -1), 32: (-1, -1), 64: (-1, 0), 128: (-1, 1)}


def brute_fill(z):
    """Planchon & Darboux (2001) iteration without epsilon: the level of a
    cell is the lowest, over 8-connected paths to the edge, of the highest
    cell on the path. Starts at +inf inside, lowers to a fixed point."""
    h, w = z.shape
    z = z.astype(np.float64)
    wv = np.full_like(z, np.inf)
    wv[0, :], wv[-1, :], wv[:, 0], wv[:, -1] = z[0, :], z[-1, :], z[:, 0], z[:, -1]
    changed = True
    while changed:
        changed = False
        for r in range(1, h - 1):
            for c in range(1, w - 1):
                m = min(wv[r + dr, c + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0))
                v = max(z[r, c], m)
                if v < wv[r, c]:
                    wv[r, c] = v
                    changed = True
    return wv


def test_fill_pit_and_nested_depression():
    z = np.full((7, 7), 10.0, dtype=np.float32)
    z[1:6, 1:6] = 5.0  # a basin whose rim is 10 ...
    z[3, 3] = 1.0  # ... with a pit in it
    z[0, 3] = 4.0  # ... and a gap in the rim at 4: the basin drains over it
    out = orogen.fill(z)
    assert out.dtype == np.float32 and out.shape == (7, 7)
    expect = brute_fill(z)
    np.testing.assert_array_equal(out, expect.astype(np.float32))
    assert out[3, 3] == 5.0 and out[0, 3] == 4.0


def test_fill_random_dem_matches_brute_force(rough_dem):
    out = orogen.fill(rough_dem)
    np.testing.assert_array_equal(out, brute_fill(rough_dem).astype(np.float32))
    assert (out >= rough_dem).all()


def test_fill_nan_is_nodata_and_an_outlet():
    z = np.full((5, 5), 10.0, dtype=np.float32)
    z[2, 2] = 2.0
    z[2, 3] = np.nan  # beside the pit: the pit drains into the hole
    out = orogen.fill(z)
    assert np.isnan(out[2, 3])
    assert out[2, 2] == 2.0
    assert np.isnan(out).sum() == 1


def test_fill_epsilon_drains_strictly():
    z = np.full((6, 6), 10.0, dtype=np.float32)
    z[1:5, 1:5] = 3.0
    z[0, 2] = 3.0  # the flat's exit
    out = orogen.fill_epsilon(z)
    # Every flat cell rose above 3 by a few ULPs, more the farther from the exit.
    inner = out[1:5, 1:5]
    assert (inner >= 3.0).all() and (inner < 3.0001).all()
    assert out[1, 2] < out[4, 4]
    # Every interior cell has a strictly lower neighbour (it drains).
    for r in range(1, 5):
        for c in range(1, 5):
            nb = [out[r + dr, c + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]
            assert min(nb) < out[r, c]


def test_breach_carves_the_pit():
    z = np.full((7, 7), 10.0, dtype=np.float32)
    z[3, 3] = 1.0
    out = orogen.breach(z)
    # The pit keeps its elevation; a channel to the edge is carved to <= 1.
    assert out[3, 3] == 1.0
    assert (out <= z).all()
    assert brute_fill(out)[3, 3] == pytest.approx(1.0)
    # least-cost within a distance, across tiles, with the remaining pits filled
    lc = orogen.breach(z, method="least-cost", dist=5, fill_remaining=True)
    assert brute_fill(lc)[3, 3] == pytest.approx(lc[3, 3])


def test_flow_d8_codes_by_hand():
    y, x = np.mgrid[0:6, 0:8].astype(np.float32)
    east = orogen.flow(-x)  # downhill to the east
    assert east.dtype == np.uint8
    assert (east[1:-1, 1:-1] == 1).all()
    south = orogen.flow(-y)  # rows grow southward
    assert (south[1:-1, 1:-1] == 4).all()
    # drop 2 over sqrt(2) beats drop 1 over 1: south-east
    se = orogen.flow(-(x + y))
    assert (se[1:-1, 1:-1] == 2).all()
    nw = orogen.flow(x + y)
    assert (nw[1:-1, 1:-1] == 32).all()


def east_plane_d8(h, w):
    """D8 codes of an ``h`` x ``w`` plane falling to the east."""
    _, x = np.mgrid[0:h, 0:w].astype(np.float32)
    return orogen.flow(-x)


def d8_path(d8, r, c):
    """The cells of the D8 path from (r, c) to where it leaves the grid or
    stops (code 0 or nodata), walked by hand."""
    h, w = d8.shape
    path = []
    while 0 <= r < h and 0 <= c < w and len(path) <= h * w:
        path.append((r, c))
        code = int(d8[r, c])
        if code not in D8:
            break
        dr, dc = D8[code]
        r, c = r + dr, c + dc
    return path


def test_accumulate_counts_upstream_cells():
    acc = orogen.accumulate(east_plane_d8(5, 9))
    assert acc.dtype == np.float64
    # In every row each cell drains the cells west of it and itself.
    for r in range(1, 4):
        np.testing.assert_array_equal(acc[r, :], np.arange(1, 10, dtype=np.float64))


def test_accumulate_in_true_areas_on_lat_lon():
    """A 1-degree band at 60 N flowing east: each cell is the area of a
    1 x 1 degree quadrangle of WGS 84, integrated here numerically from the
    area element M(p) N(p) cos p (the radii of curvature)."""
    d8 = np.ones((1, 8), dtype=np.uint8)
    d8[0, 7] = 0
    t = (0.0, 1.0, 0.0, 61.0, 0.0, -1.0)
    km2 = orogen.accumulate(d8, units="km2", transform=t, crs=4326, nodata=255)
    a, e2 = 6378.137, 0.006694379990141317
    p = np.radians(np.linspace(60.0, 61.0, 2001))
    w = np.sqrt(1 - e2 * np.sin(p) ** 2)
    f = (a * (1 - e2) / w ** 3) * (a / w) * np.cos(p)
    trap = getattr(np, "trapezoid", None) or np.trapz
    cell = trap(f, p) * np.radians(1.0)
    np.testing.assert_allclose(km2[0], cell * np.arange(1, 9), rtol=1e-6)
    sca = orogen.accumulate(d8, units="sca", transform=t, crs=4326, nodata=255)
    np.testing.assert_allclose(sca[0] * np.sqrt(km2[0, 0] * 1e6), km2[0] * 1e6, rtol=1e-6)
    with pytest.raises(orogen.InvalidInputError, match="no georeferencing"):
        orogen.accumulate(d8, units="m2")


def test_accumulate_random_dem_matches_path_walk(rough_dem):
    d8 = orogen.flow(orogen.fill(rough_dem))
    acc = orogen.accumulate(d8)
    expect = np.zeros(d8.shape)
    for r in range(d8.shape[0]):
        for c in range(d8.shape[1]):
            for cell in d8_path(d8, r, c):
                expect[cell] += 1
    np.testing.assert_array_equal(acc, expect)


def test_watersheds_label_the_outlet(rough_dem):
    ws = orogen.watersheds(east_plane_d8(4, 6))
    assert ws.dtype == np.uint32
    # Each row drains east and leaves at its last cell: label = row-major index + 1.
    for r in range(1, 3):
        assert (ws[r, :] == r * 6 + 5 + 1).all()
    d8 = orogen.flow(orogen.fill(rough_dem))
    labels = orogen.watersheds(d8)
    w = d8.shape[1]
    for r in range(0, d8.shape[0], 3):
        for c in range(0, w, 3):
            er, ec = d8_path(d8, r, c)[-1]
            assert labels[r, c] == er * w + ec + 1


def horn(z, cell):
    """Horn (1981) gradient of the interior, in closed form (numpy)."""
    a, b, c = z[:-2, :-2], z[:-2, 1:-1], z[:-2, 2:]
    d, f = z[1:-1, :-2], z[1:-1, 2:]
    g, hh, i = z[2:, :-2], z[2:, 1:-1], z[2:, 2:]
    dzdx = ((c + 2 * f + i) - (a + 2 * d + g)) / (8 * cell)
    dzdy = ((g + 2 * hh + i) - (a + 2 * b + c)) / (8 * cell)
    return dzdx, dzdy


def test_slope_on_a_plane_is_closed_form():
    cell = 10.0
    y, x = np.mgrid[0:8, 0:9].astype(np.float64)
    z = (0.3 * x * cell + 0.4 * y * cell).astype(np.float32)  # grade 0.3 east, 0.4 south
    s = orogen.slope(z, transform=(0.0, cell, 0.0, 0.0, 0.0, -cell), crs=32633)
    expect = math.degrees(math.atan(0.5))
    np.testing.assert_allclose(s[1:-1, 1:-1], expect, atol=1e-4)
    assert np.isnan(s[0, :]).all() and np.isnan(s[:, -1]).all()  # edges: nodata
    pct = orogen.slope(z, units="percent", transform=(0.0, cell, 0.0, 0.0, 0.0, -cell), crs=32633)
    np.testing.assert_allclose(pct[1:-1, 1:-1], 50.0, atol=1e-3)
    edges = orogen.slope(z, compute_edges=True, transform=(0.0, cell, 0.0, 0.0, 0.0, -cell), crs=32633)
    assert not np.isnan(edges).any()


def test_slope_matches_numpy_horn(rough_dem):
    cell = 30.0
    s = orogen.slope(rough_dem, transform=(500000.0, cell, 0.0, 4e6, 0.0, -cell), crs=32633)
    dzdx, dzdy = horn(rough_dem.astype(np.float64), cell)
    expect = np.degrees(np.arctan(np.hypot(dzdx, dzdy)))
    np.testing.assert_allclose(s[1:-1, 1:-1], expect, atol=1e-4)


def test_aspect_faces_downhill():
    y, x = np.mgrid[0:6, 0:6].astype(np.float32)
    east = orogen.aspect(-x)  # falls to the east: faces east
    np.testing.assert_allclose(east[1:-1, 1:-1], 90.0, atol=1e-4)
    south = orogen.aspect(-y)  # rows grow southward (north-up): faces south
    np.testing.assert_allclose(south[1:-1, 1:-1], 180.0, atol=1e-4)
    flat = np.zeros((5, 5), dtype=np.float32)
    assert np.isnan(orogen.aspect(flat)[1:-1, 1:-1]).all()
    assert (orogen.aspect(flat, zero_for_flat=True)[1:-1, 1:-1] == 0).all()


def test_hillshade_gdaldem_formula(rough_dem):
    cell = 30.0
    hs = orogen.hillshade(rough_dem, transform=(0.0, cell, 0.0, 0.0, 0.0, -cell), crs=32633)
    assert hs.dtype == np.uint8
    assert (hs[0, :] == 0).all()  # edges: nodata 0
    # Lambert: the cosine between the surface normal (-dz/dX, -dz/dY, 1)
    # and the direction of the sun (X east, Y north; rows grow southward).
    dzdx, dzdy = horn(rough_dem.astype(np.float64), cell)
    alt, az = math.radians(45.0), math.radians(315.0)
    gx, gy = dzdx, -dzdy
    sun = (math.sin(az) * math.cos(alt), math.cos(az) * math.cos(alt), math.sin(alt))
    cang = (-gx * sun[0] - gy * sun[1] + sun[2]) / np.sqrt(1 + gx**2 + gy**2)
    expect = np.where(cang <= 0, 1.0, 1 + 254 * cang)
    assert np.abs(hs[1:-1, 1:-1].astype(np.float64) - expect).max() <= 1.0


def test_metrics_window_statistics(rough_dem):
    out = orogen.metrics(rough_dem, ["tpi:radius=1c", "relief:radius=1c"])
    assert len(out) == 2
    tpi = next(v for k, v in out.items() if k.startswith("tpi"))
    relief = next(v for k, v in out.items() if k.startswith("relief"))
    z = rough_dem.astype(np.float64)
    win = np.stack([z[1 + dr:z.shape[0] - 1 + dr, 1 + dc:z.shape[1] - 1 + dc]
                    for dr in (-1, 0, 1) for dc in (-1, 0, 1)])
    others = np.delete(win, 4, axis=0)
    np.testing.assert_allclose(tpi[1:-1, 1:-1], z[1:-1, 1:-1] - others.mean(axis=0), atol=1e-3)
    np.testing.assert_allclose(relief[1:-1, 1:-1], win.max(axis=0) - win.min(axis=0), atol=1e-3)


def prominence_oracle(z, r, c):
    """Prominence of the peak at (r, c) by flood fills: the key col is the
    highest level t such that the cells >= t 8-connected to the peak
    include a higher cell; edge convention sea level (the outside is 0)."""
    h, w = z.shape
    levels = sorted(set(z.ravel().tolist()) | {0.0}, reverse=True)
    peak = z[r, c]
    for t in levels:
        if t > peak:
            continue
        seen = np.zeros_like(z, dtype=bool)
        stack = [(r, c)]
        seen[r, c] = True
        found = False
        while stack and not found:
            rr, cc = stack.pop()
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    nr, nc = rr + dr, cc + dc
                    if 0 <= nr < h and 0 <= nc < w and not seen[nr, nc] and z[nr, nc] >= t:
                        if z[nr, nc] > peak:
                            found = True
                        seen[nr, nc] = True
                        stack.append((nr, nc))
        if found:
            return peak - t
    return peak  # the highest peak: down to sea level


def test_peaks_prominence_against_flood_fill():
    y, x = np.mgrid[0:30, 0:40].astype(np.float64)
    z = 100 * np.exp(-((x - 10) ** 2 + (y - 15) ** 2) / 30) + 70 * np.exp(-((x - 30) ** 2 + (y - 15) ** 2) / 30)
    z = np.round(z + 5, 2).astype(np.float32)
    t = orogen.peaks(z, min_prominence=10)
    assert set(["elevation", "prominence", "col", "row"]) <= set(t)
    assert len(t["elevation"]) == 2
    for k in range(2):
        r, c = int(t["row"][k]), int(t["col"][k])
        assert t["elevation"][k] == pytest.approx(float(z[r, c]))
        assert t["prominence"][k] == pytest.approx(prominence_oracle(z.astype(np.float64), r, c), abs=1e-4)
    cols = sorted(int(c) for c in t["col"])
    assert cols == [10, 30]


def test_peaks_as_dataframe():
    pd = pytest.importorskip("pandas")
    z = np.zeros((9, 9), dtype=np.float32)
    z[4, 4] = 50
    df = orogen.peaks(z, min_prominence=1, as_dataframe=True)
    assert isinstance(df, pd.DataFrame) and len(df) == 1
    assert df["prominence"][0] == 50


def test_synth_noise_is_the_clis_bytes(cli, tmp_path):
    """orogen.synth.noise equals `orogen synth noise` with the same options,
    in memory and written to a file; an unknown option is refused naming it."""
    out = tmp_path / "noise.tif"
    subprocess.run([cli, "synth", "noise", "--size", "96x80", "--seed", "11", "--kind", "ridged",
                    "--amplitude", "800", "--cell", "25", "-o", str(out), "-q"], check=True)
    want = orogen.open(out).read()
    got = orogen.synth.noise((96, 80), seed=11, kind="ridged", amplitude=800.0, cell=25.0)
    assert got.shape == (80, 96) and got.dtype == want.dtype
    assert got.tobytes() == want.tobytes()
    f = orogen.synth.noise("96x80", seed=11, kind="ridged", amplitude=800.0, cell=25.0, output=tmp_path / "py.tif")
    assert f.read().tobytes() == want.tobytes()
    assert float(np.ptp(got)) > 100.0  # real relief, not a constant
    with pytest.raises(orogen.InvalidInputError, match="octaves_typo|octaves-typo"):
        orogen.synth.noise(16, octaves_typo=3)
