// The page's frame rate in headless Chromium: opens URL at WIDTHxHEIGHT, lets it run for SECONDS and
// prints the median and the minimum of the per-second rates the page itself counts (requestAnimationFrame),
// with the renderer WebGL reports (software rendering shows as SwiftShader).
//
//   node measure_fps.mjs URL [SECONDS] [WIDTHxHEIGHT]
import { chromium } from 'playwright-core';
import { launchOptions } from '../chromium.mjs';

const url = process.argv[2], seconds = Number(process.argv[3] ?? 10), [w, h] = (process.argv[4] ?? '1280x720').split('x').map(Number);
const browser = await chromium.launch(launchOptions());
const page = await browser.newPage({ viewport: { width: w, height: h } });
const errors = [];
page.on('pageerror', (e) => errors.push(e.message));
await page.goto(url);
await page.evaluate(() => window.hpr.ready);
await page.waitForTimeout(2000);  // meshes uploaded, first frames
const rates = [];
for (let i = 0; i < seconds; ++i) {
  await page.waitForTimeout(1000);
  rates.push(await page.evaluate(() => window.hpr.fps));
}
const renderer = await page.evaluate(() => {
  const gl = document.createElement('canvas').getContext('webgl2');
  const ext = gl.getExtension('WEBGL_debug_renderer_info');
  return ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
});
const sorted = rates.slice().sort((a, b) => a - b);
console.log(JSON.stringify({ url, size: `${w}x${h}`, median_fps: sorted[Math.floor(sorted.length / 2)], min_fps: sorted[0], renderer, errors }));
await browser.close();
