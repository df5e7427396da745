// Opens the orogen viewer in headless Chromium (playwright-core), waits for
// MapLibre to finish rendering, saves a screenshot and checks it is not blank.
// Usage: node tools/viewer_check.mjs URL SCREENSHOT.png
import { chromium } from 'playwright-core';
const [url, shot] = process.argv.slice(2);
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
console.log(logs.join('\n'));
await browser.close();
console.log(`rendered: ${distinct} distinct colours; screenshot ${shot}`);
if (distinct < 20) { console.error('the rendered map looks blank'); process.exit(1); }
