// Opens the orogen viewer in headless Chromium (playwright-core), waits for
// MapLibre to finish rendering, saves a screenshot and checks it is not blank;
// with POINTS (a JSON list of [lon, lat, elevation m, tolerance m], the
// elevations read from the DEM by GDAL), checks that MapLibre's own terrain
// decoder gives each point's elevation (divided by the terrain's
// exaggeration) within its tolerance: a wrong encoding, offset or nodata
// shaft fails here.
// Usage: node tools/viewer_check.mjs URL SCREENSHOT.png [POINTS.json]
import { chromium } from 'playwright-core';
import { readFileSync } from 'node:fs';
const [url, shot, pointsFile] = process.argv.slice(2);
const browser = await chromium.launch({ executablePath: '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-gl=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'] });
const page = await browser.newPage({ viewport: { width: 900, height: 600 } });
const logs = [];
page.on('console', (m) => logs.push(m.text()));
await page.goto(url);
try {
  await page.waitForFunction(() => window.mapReady === true || window.mapError, null, { timeout: 90000 });
} catch (e) {
  console.error('map did not become idle:', logs.join('\n'));
  process.exit(1);
}
const err = await page.evaluate(() => window.mapError || null);
if (err) { console.error('map error:', err); process.exit(1); }
await page.screenshot({ path: shot });
// Distinct colours in the rendered canvas: a blank map has one or two.
const distinct = await page.evaluate(() => {
  const c = window.map.getCanvas();
  const gl = c.getContext('webgl2') || c.getContext('webgl');
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const s = new Set();
  for (let i = 0; i < px.length; i += 4 * 97) s.add((px[i] << 16) | (px[i + 1] << 8) | px[i + 2]);
  return s.size;
});
const points = pointsFile ? JSON.parse(readFileSync(pointsFile, 'utf8')) : [];
const got = await page.evaluate((pts) => {
  const ex = window.map.getTerrain() ? window.map.getTerrain().exaggeration : null;
  // The terrain's own lookup (times the exaggeration). Its zoom argument is
  // that of the render tiles, deltaZoom deeper than the terrain tiles it
  // holds (map.queryTerrainElevation passes the view's tile zoom, which
  // finds no terrain tile here and answers 0).
  const t = window.map.terrain;
  if (!t) return { ex, z: pts.map(() => null) };
  const zs = Object.values(t.tileManager._tiles).map((tile) => tile.tileID.overscaledZ);
  const tz = Math.max(...zs) + (t.tileManager.deltaZoom || 0);
  return { ex, tz, z: pts.map(([lon, lat]) => t.getElevationForLngLatZoom(new maplibregl.LngLat(lon, lat), tz)) };
}, points);
console.log(logs.join('\n'));
await browser.close();
console.log(`rendered: ${distinct} distinct colours; screenshot ${shot}`);
if (distinct < 20) { console.error('the rendered map looks blank'); process.exit(1); }
let bad = 0;
points.forEach(([lon, lat, want, tol], i) => {
  const z = got.z[i];
  const m = z === null || !got.ex ? null : z / got.ex;
  const ok = m !== null && Math.abs(m - want) <= tol;
  if (!ok) bad++;
  console.log(`${ok ? 'PASS' : 'FAIL'}: terrain at ${lon}, ${lat}: MapLibre ${m === null ? 'none' : m.toFixed(1)} m ` +
    `(zoom ${got.tz} terrain tiles, exaggeration ${got.ex}), DEM ${want.toFixed(1)} m, tolerance ${tol} m`);
});
if (bad) { console.error(`${bad} terrain elevations off`); process.exit(1); }
