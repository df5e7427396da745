#!/usr/bin/env python3
"""Compare orogen's Priority-Flood fill with RichDEM's on a real DEM.

Usage:  python3 tools/richdem_compare.py [--max-differ N] DEM.tif [more.tif ...]

For each DEM: GDAL converts it to raw float32 (nodata kept as its value),
RichDEM's FillDepressions (epsilon=False) fills it and is timed, then the
bench binary `benches/hydro_perf.rs` (release build, `richdem_fill_matches`)
times orogen's fill on the same raw file and compares the two results bit
for bit. Prints one line per DEM: cells, differing cells, both timings and
the ratio. Exits 1 when any DEM has more than --max-differ (default 0)
differing valid cells or any nodata mismatch: both are Priority-Flood fills
without epsilon, so they must agree bit for bit (the CI's RichDEM gate on a
real DEM is tools/python_peers.py, which needs no bench build).

Installing RichDEM: `pip install richdem` (0.3.4, the last release) does not
build on Python 3.11 because its bundled pybind11 is too old. Build it with
the current pybind11 headers instead:
    pip install pybind11 'numpy<2'
    pip download richdem==0.3.4 --no-deps --no-binary :all: -d /tmp/rd
    cd /tmp/rd && tar xzf richdem-0.3.4.tar.gz && cd richdem-0.3.4
    rm -rf lib/pybind11 && cp -r "$(python3 -c 'import pybind11;print(pybind11.get_include())')/pybind11" lib/
    pip install .
"""
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import richdem as rd

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def gdal_size_nodata(path):
    out = subprocess.run(["gdalinfo", path], capture_output=True, text=True, check=True).stdout
    w = h = None
    nodata = None
    for line in out.splitlines():
        line = line.strip()
        if line.startswith("Size is"):
            w, h = [int(v) for v in line[len("Size is"):].split(",")]
        if line.startswith("NoData Value="):
            nodata = float(line.split("=", 1)[1])
    return w, h, nodata


def main(paths, max_differ):
    bad = []
    subprocess.run(
        ["cargo", "bench", "--bench", "hydro_perf", "--no-run", "-q"],
        cwd=ROOT, check=True)
    with tempfile.TemporaryDirectory() as tmp:
        for path in paths:
            w, h, nodata = gdal_size_nodata(path)
            if nodata is None:
                nodata = -3.4e38
            raw = os.path.join(tmp, "dem.f32")
            subprocess.run(["gdal_translate", "-q", "-of", "ENVI", "-ot", "Float32", path, raw],
                           check=True)
            nodata32 = float(np.float32(nodata))
            a = np.fromfile(raw, dtype="<f4").reshape(h, w)
            dem = rd.rdarray(a.copy(), no_data=nodata32)
            t = time.perf_counter()
            filled = rd.FillDepressions(dem, epsilon=False, in_place=False)
            t_rd = time.perf_counter() - t
            out = os.path.join(tmp, "richdem.f32")
            np.asarray(filled, dtype="<f4").tofile(out)
            env = dict(os.environ)
            env["OROGEN_HYDRO_RICHDEM"] = f"{raw}:{w}:{h}:{nodata32!r}:{out}"
            res = subprocess.run(
                ["cargo", "bench", "--bench", "hydro_perf", "-q"],
                cwd=ROOT, env=env, capture_output=True, text=True)
            line = [l for l in res.stderr.splitlines() if l.startswith("richdem-compare")]
            if res.returncode != 0 or not line:
                print(res.stdout, res.stderr, file=sys.stderr)
                sys.exit(f"{path}: comparison failed")
            # richdem-compare cells=N differ=M orogen_s=T
            fields = dict(kv.split("=") for kv in line[0].split()[1:])
            t_or = float(fields["orogen_s"])
            print(f"{os.path.basename(path)}: {w}x{h}, {fields['differ']} of {fields['cells']} "
                  f"valid cells differ ({fields['richdem_higher']} higher in RichDEM, "
                  f"{fields['nodata_differ']} nodata mismatches); RichDEM {t_rd:.3f} s, orogen {t_or:.3f} s, "
                  f"orogen is {t_rd / t_or:.2f}x RichDEM's speed")
            if int(fields["differ"]) > max_differ or int(fields["nodata_differ"]) > 0:
                bad.append(os.path.basename(path))
    if bad:
        print(f"FAIL: fills differ from RichDEM's (more than {max_differ} cells, or nodata) on: {', '.join(bad)}")
        return 1
    return 0


if __name__ == "__main__":
    args = sys.argv[1:]
    max_differ = 0
    if len(args) >= 2 and args[0] == "--max-differ":
        max_differ, args = int(args[1]), args[2:]
    if not args:
        sys.exit(__doc__)
    sys.exit(main(args, max_differ))
